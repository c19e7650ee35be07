#include "core/io/frame_quality.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/common/format.h"
#include "core/io/kinematics.h"

namespace wormdrag {
namespace {

bool ParseNumber(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(*out);
}

}  // namespace

std::string QualityPathFor(const std::string& kinematics_path) {
  const std::string ext = ".csv";
  if (kinematics_path.size() > ext.size() &&
      kinematics_path.compare(kinematics_path.size() - ext.size(), ext.size(), ext) == 0)
    return kinematics_path.substr(0, kinematics_path.size() - ext.size()) + ".quality.csv";
  return kinematics_path + ".quality.csv";
}

std::string FormatFrameQuality(const std::vector<FrameQuality>& rows) {
  std::string out =
      "# wormdrag track: per-frame quality (docs/video.md); quality = IoU of the body re-drawn from the skeleton "
      "against the worm's mask, 0 when missing\nframe,t,status,quality\n";
  char buf[96];
  for (const FrameQuality& r : rows) {
    std::snprintf(buf, sizeof buf, "%d,%.6f,", r.frame, r.t);
    out += buf;
    out += r.status;
    std::snprintf(buf, sizeof buf, ",%.4f\n", r.quality);
    out += buf;
  }
  return out;
}

Status WriteFrameQuality(const std::vector<FrameQuality>& rows, const std::string& path) {
  return WriteFileAtomically(path, FormatFrameQuality(rows));
}

Result<std::vector<FrameQuality>> ParseFrameQuality(std::string_view text, const std::string& name) {
  std::vector<FrameQuality> rows;
  std::istringstream in{std::string(text)};
  std::string line;
  bool header = false;
  for (int lineno = 1; std::getline(in, line); ++lineno) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const std::string where = name + ":" + std::to_string(lineno) + ": ";
    if (!header) {
      if (line != "frame,t,status,quality")
        return Status::InvalidArgument(where + "header must be 'frame,t,status,quality', got '" + line + "'");
      header = true;
      continue;
    }
    const std::vector<std::string> cells = SplitList(line);
    if (cells.size() != 4)
      return Status::InvalidArgument(where + "expected 4 columns, got " + std::to_string(cells.size()));
    FrameQuality r;
    double frame = 0;
    if (!ParseNumber(cells[0], &frame) || frame != std::floor(frame) || frame < 0)
      return Status::InvalidArgument(where + "column 1 (frame): not a frame number '" + cells[0] + "'");
    r.frame = static_cast<int>(frame);
    if (!ParseNumber(cells[1], &r.t))
      return Status::InvalidArgument(where + "column 2 (t): not a number '" + cells[1] + "'");
    if (cells[2].empty()) return Status::InvalidArgument(where + "column 3 (status): empty");
    r.status = cells[2];
    if (!ParseNumber(cells[3], &r.quality) || r.quality < 0 || r.quality > 1)
      return Status::InvalidArgument(where + "column 4 (quality): not a number in [0, 1] '" + cells[3] + "'");
    rows.push_back(std::move(r));
  }
  if (!header) return Status::InvalidArgument(name + ": no header row 'frame,t,status,quality' found");
  return rows;
}

Result<std::vector<FrameQuality>> ReadFrameQuality(const std::string& path) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  return ParseFrameQuality(*text, path);
}

Result<std::string> MaskLowQualityFrames(std::string_view kinematics_text, const std::string& kinematics_name,
                                         const std::vector<FrameQuality>& quality, const std::string& quality_name,
                                         double min_quality, int* masked) {
  if (!(min_quality >= 0 && min_quality <= 1)) return Status::InvalidArgument("the minimum quality must lie in [0, 1]");
  std::string out;
  out.reserve(kinematics_text.size() + 64);
  std::istringstream in{std::string(kinematics_text)};
  std::string line;
  bool header = false;
  size_t row = 0;
  int count = 0;
  for (int lineno = 1; std::getline(in, line); ++lineno) {
    const bool cr = !line.empty() && line.back() == '\r';
    if (cr) line.pop_back();
    if (line.empty() || line[0] == '#' || !header) {
      header = header || (!line.empty() && line[0] != '#');
      out += line + (cr ? "\r\n" : "\n");
      continue;
    }
    const std::string where = kinematics_name + ":" + std::to_string(lineno) + ": ";
    if (row >= quality.size())
      return Status::InvalidArgument(where + "more frames than the " + std::to_string(quality.size()) + " rows of " +
                                     quality_name);
    std::vector<std::string> cells = SplitList(line);
    double t = 0;
    if (cells.empty() || !ParseNumber(cells[0], &t))
      return Status::InvalidArgument(where + "column 1 (t): not a number");
    const FrameQuality& q = quality[row++];
    if (std::abs(t - q.t) > 1e-5)
      return Status::InvalidArgument(where + "t = " + cells[0] + " s, but " + quality_name + " has frame " +
                                     std::to_string(q.frame) + " at " + std::to_string(q.t) +
                                     " s: the quality file belongs to another recording");
    if (q.quality < min_quality) {
      bool was_valid = false;
      for (size_t c = 1; c < cells.size(); ++c) {
        double v;
        was_valid = was_valid || ParseNumber(cells[c], &v);
        cells[c] = "nan";
      }
      count += was_valid;
      line = cells[0];
      for (size_t c = 1; c < cells.size(); ++c) line += "," + cells[c];
    }
    out += line + (cr ? "\r\n" : "\n");
  }
  if (row != quality.size())
    return Status::InvalidArgument(kinematics_name + ": " + std::to_string(row) + " frames, but " + quality_name +
                                   " has " + std::to_string(quality.size()) + " rows");
  if (masked) *masked = count;
  return out;
}

}  // namespace wormdrag
