#include "core/io/kymogram.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <regex>

namespace wormdrag {

Result<NpyArray> ParseNpy(const std::string& bytes, const std::string& name) {
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0)
    return Status::InvalidArgument(name + ": not a .npy file (bad magic)");
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len, offset;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) return Status::InvalidArgument(name + ": truncated .npy header");
    header_len = 0;
    for (int i = 0; i < 4; ++i) header_len |= static_cast<size_t>(static_cast<unsigned char>(bytes[8 + i])) << (8 * i);
    offset = 12;
  } else {
    return Status::InvalidArgument(name + ": unsupported .npy version " + std::to_string(major));
  }
  // NumPy itself refuses headers over 10 000 bytes (max_header_size) for the same reason:
  // parsing a longer one costs time and stack in proportion.
  if (header_len > 10000)
    return Status::InvalidArgument(name + ": .npy header of " + std::to_string(header_len) +
                                   " bytes; at most 10000 are supported");
  if (bytes.size() < offset + header_len) return Status::InvalidArgument(name + ": truncated .npy header");
  const std::string header = bytes.substr(offset, header_len);
  // Compiled once: building a std::regex costs far more than matching a header.
  static const std::regex kDescr("'descr'\\s*:\\s*'([<>|=]?)([a-z])(\\d+)'");
  static const std::regex kFortran("'fortran_order'\\s*:\\s*True");
  static const std::regex kShape("'shape'\\s*:\\s*\\(\\s*(\\d+)\\s*,\\s*(\\d+)\\s*,?\\s*\\)");
  std::smatch m;
  if (!std::regex_search(header, m, kDescr)) return Status::InvalidArgument(name + ": .npy header has no 'descr'");
  const std::string order = m[1], kind = m[2], size = m[3];
  if (kind != "f" || size != "8")
    return Status::InvalidArgument(name + ": 'descr' is '" + m[0].str() + "', only float64 ('<f8') is supported");
  const bool big_endian = order == ">";
  if (std::regex_search(header, kFortran))
    return Status::InvalidArgument(name + ": 'fortran_order' is True, only C order is supported");
  if (!std::regex_search(header, m, kShape))
    return Status::InvalidArgument(name + ": 'shape' must be 2-D (rows, columns)");
  // The shape is checked against the data the file holds before anything is sized
  // from it: a header may claim any number of digits.
  const size_t data_start = offset + header_len;
  const size_t have = (bytes.size() - data_start) / 8;  // float64 values present
  auto dim = [&](const std::string& digits, int* out) {
    uint64_t v = 0;
    for (char c : digits) {
      v = v * 10 + static_cast<uint64_t>(c - '0');
      if (v > static_cast<uint64_t>(std::numeric_limits<int>::max())) return false;
    }
    *out = static_cast<int>(v);
    return true;
  };
  NpyArray a;
  if (!dim(m[1], &a.rows) || !dim(m[2], &a.cols) ||
      (a.cols > 0 && static_cast<uint64_t>(a.rows) > have / static_cast<uint64_t>(a.cols)))
    return Status::InvalidArgument(name + ": 'shape' (" + m[1].str() + ", " + m[2].str() +
                                   ") needs more data than the " + std::to_string(have) + " values the file holds");
  const size_t n = static_cast<size_t>(a.rows) * a.cols;
  if (a.rows > kMaxFrames)
    return Status::InvalidArgument(name + ": 'shape' has " + std::to_string(a.rows) + " rows; at most " +
                                   std::to_string(kMaxFrames) + " frames are supported");
  a.data.resize(n);
  for (size_t i = 0; i < n; ++i) {
    unsigned char b[8];
    std::memcpy(b, bytes.data() + data_start + 8 * i, 8);
    if (big_endian) std::reverse(b, b + 8);  // this reader runs on little-endian hosts
    std::memcpy(&a.data[i], b, 8);
  }
  return a;
}

Result<NpyArray> ReadNpy(const std::string& path) {
  auto bytes = ReadFile(path);
  if (!bytes.ok()) return bytes.status();
  return ParseNpy(*bytes, path);
}

Result<Kinematics> KymogramToKinematics(const NpyArray& kymo, const KymogramOptions& opt, const std::string& name) {
  if (!(opt.fps > 0))
    return Status::InvalidArgument(name + ": a kymogram has no time base; give its frame rate (--fps)");
  if (kymo.cols < 2) return Status::InvalidArgument(name + ": a kymogram needs at least 2 angles per row");
  Kinematics k;
  k.fps = opt.fps;
  k.metadata["fps"] = std::to_string(opt.fps);
  k.metadata["source"] = "joint-angle kymogram " + name;
  k.metadata["positions"] = "none: shape only, unit body length, head at the origin";
  const int rods = kymo.cols + 1;
  const double rod = 1.0 / rods;
  k.frames.resize(kymo.rows);
  for (int r = 0; r < kymo.rows; ++r) {
    Frame& f = k.frames[r];
    f.t = r / opt.fps;
    std::vector<Vec2> line(rods + 1);
    line[0] = Vec2::Zero();
    double phi = 0;
    bool ok = true;
    for (int j = 0; j < rods; ++j) {
      if (j > 0) {
        const double a = kymo.at(r, j - 1);
        if (!std::isfinite(a)) {
          ok = false;
          break;
        }
        phi += opt.flip_sign ? -a : a;
      }
      line[j + 1] = line[j] + rod * Vec2(std::cos(phi), std::sin(phi));
    }
    if (!ok) continue;
    auto pts = ResampleByArcLength(line);
    if (!pts.ok()) continue;
    f.valid = true;
    f.p = *pts;
    f.arc_length = 1.0;
  }
  return k;
}

}  // namespace wormdrag
