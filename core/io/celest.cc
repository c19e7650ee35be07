#include "core/io/celest.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "core/common/format.h"
#include "core/io/internal/celest_frames.h"

namespace wormdrag {
namespace {

using celest_internal::Candidate;
using celest_internal::Classify;
using celest_internal::DropGlitches;
using celest_internal::OrderHeadTail;
using celest_internal::RawFrame;
using celest_internal::Reason;

struct Header {
  int worms = 0, frames = 0, precision = -1;
  int worms_line = 0;
};

std::string_view TrimView(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool ParseInt(std::string_view s, long* out) {
  const std::string c(TrimView(s));
  if (c.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *out = std::strtol(c.c_str(), &end, 10);
  return *end == '\0' && errno != ERANGE;
}

// At most 40 characters of `s`, for quoting input in a message.
std::string Clip(std::string_view s) {
  return s.size() <= 40 ? std::string(s) : std::string(s.substr(0, 37)) + "...";
}

// "12,34,56," → {12, 34, 56}; the trailing comma CeleST writes is optional.
bool ParseIntList(std::string_view s, std::vector<long>* out) {
  out->clear();
  s = TrimView(s);
  if (!s.empty() && s.back() == ',') s.remove_suffix(1);
  if (s.empty()) return true;
  size_t start = 0;
  for (size_t i = 0; i <= s.size(); ++i) {
    if (i < s.size() && s[i] != ',') continue;
    long v;
    if (!ParseInt(s.substr(start, i - start), &v)) return false;
    out->push_back(v);
    start = i + 1;
  }
  return true;
}

// Reads the file; only the chosen worm's records are kept, every line is checked.
class Parser {
 public:
  Parser(const CelestOptions& opt, const std::string& name) : opt_(opt), name_(name) {}

  Status Run(std::string_view text) {
    size_t pos = 0;
    while (pos < text.size()) {
      size_t nl = text.find('\n', pos);
      if (nl == std::string_view::npos) nl = text.size();
      const std::string_view line = TrimView(text.substr(pos, nl - pos));
      pos = nl + 1;
      ++lineno_;
      if (line.empty()) continue;
      const size_t sp = line.find_first_of(" \t");
      const std::string key(line.substr(0, sp));
      const std::string_view value = sp == std::string_view::npos ? std::string_view() : TrimView(line.substr(sp));
      Status st = key == "worm" ? StartRecord(value) : in_records_ ? Field(key, value) : HeaderLine(key, value);
      if (!st.ok()) return st;
    }
    if (!in_records_) WORMDRAG_RETURN_IF_ERROR(HeaderComplete());
    return EndRecord();
  }

  const std::vector<RawFrame>& frames() const { return frames_; }

 private:
  Status Error(const std::string& what) const {
    return Status::InvalidArgument(name_ + ":" + std::to_string(lineno_) + ": " + what);
  }

  Status HeaderLine(const std::string& key, std::string_view value) {
    long v = 0;
    if (key == "format" || key == "block") return Status::Ok();
    if (key == "version")
      return Error("CeleST version " + Clip(value) + " files (extra per-frame fields) are not supported");
    if (key != "worms" && key != "frames" && key != "precision")
      return Error("'" + Clip(key) +
                   "' is neither a header line (format, block, worms, frames, precision) nor a record");
    if (!ParseInt(value, &v) || v < (key == "precision" ? 0 : 1) || v > (key == "precision" ? 9 : 1000000))
      return Error(key + ": not a valid count '" + Clip(value) + "'");
    if (key == "worms") {
      header_.worms = static_cast<int>(v);
      header_.worms_line = lineno_;
    }
    if (key == "frames") header_.frames = static_cast<int>(v);
    if (key == "precision") header_.precision = static_cast<int>(v);
    return Status::Ok();
  }

  Status HeaderComplete() {
    for (auto [key, v] :
         {std::pair{"worms", header_.worms}, {"frames", header_.frames}, {"precision", header_.precision}})
      if (v < 0 || (v == 0 && std::string(key) != "precision"))
        return Status::InvalidArgument(name_ + ": header line '" + key + " N' missing before the first record");
    if (opt_.worm < 1 || opt_.worm > header_.worms)
      return Status::InvalidArgument(name_ + ":" + std::to_string(header_.worms_line) + ": worms " +
                                     std::to_string(header_.worms) + ": there is no worm " + std::to_string(opt_.worm) +
                                     " (the file has worms 1-" + std::to_string(header_.worms) + ")");
    frames_.assign(header_.frames, RawFrame{});
    scale_ = std::pow(10.0, -header_.precision);
    return Status::Ok();
  }

  Status StartRecord(std::string_view value) {
    if (!in_records_) {
      WORMDRAG_RETURN_IF_ERROR(HeaderComplete());
      in_records_ = true;
    }
    WORMDRAG_RETURN_IF_ERROR(EndRecord());
    std::istringstream in{std::string(value)};
    std::string a, b, c, d;
    long worm = 0, frame = 0;
    in >> a >> b >> c >> d;
    if (b != "frame" || c.empty() || !d.empty() || !ParseInt(a, &worm) || !ParseInt(c, &frame))
      return Error("record line must be 'worm WW frame FFFF', got 'worm " + Clip(value) + "'");
    if (worm < 1 || worm > header_.worms)
      return Error("worm " + Clip(a) + " is outside 1-" + std::to_string(header_.worms) + " (header 'worms')");
    if (frame < 1 || frame > header_.frames)
      return Error("frame " + Clip(c) + " is outside 1-" + std::to_string(header_.frames) + " (header 'frames')");
    record_line_ = lineno_;
    record_ = "worm " + a + " frame " + c;
    seen_.clear();
    current_ = worm == opt_.worm ? &frames_[frame - 1] : nullptr;
    if (current_ && current_->present) return Error(record_ + " appears twice");
    if (current_) current_->present = true;
    return Status::Ok();
  }

  Status Field(const std::string& key, std::string_view value) {
    static const std::string kKeys = "xywtgmlo";
    if (record_line_ == 0 || key.size() != 1 || kKeys.find(key[0]) == std::string::npos)
      return Error("unknown line '" + Clip(key) + "' in " + record_ + " (expected x, y, w, t, g, m, l or o)");
    if (seen_.find(key[0]) != std::string::npos) return Error(record_ + ": field '" + key + "' appears twice");
    seen_ += key[0];
    std::vector<long> v;
    if (!ParseIntList(value, &v))
      return Error(record_ + ": field '" + key + "': not a list of integers '" + Clip(value) + "'");
    const bool list = key == "x" || key == "y" || key == "w";
    if (!list && v.size() != 1)
      return Error(record_ + ": field '" + key + "': expected one value, got " + std::to_string(v.size()));
    const bool flag = key == "m" || key == "l" || key == "o";
    if (flag && v[0] != 0 && v[0] != 1)
      return Error(record_ + ": field '" + key + "': a flag is 0 or 1, got " + std::to_string(v[0]));
    if (key == "x") x_ = v;
    if (key == "y") {
      if (seen_.find('x') == std::string::npos) return Error(record_ + ": field 'y' before 'x'");
      if (v.size() != x_.size())
        return Error(record_ + ": field 'y' has " + std::to_string(v.size()) + " values, 'x' has " +
                     std::to_string(x_.size()));
      if (current_) {
        current_->px.resize(v.size());
        for (size_t i = 0; i < v.size(); ++i) current_->px[i] = Vec2(x_[i] * scale_, v[i] * scale_);
      }
    }
    if (current_ && key == "l") current_->lost = v[0];
    if (current_ && key == "m") current_->missed = v[0];
    if (current_ && key == "o") current_->overlapped = v[0];
    return Status::Ok();
  }

  Status EndRecord() {
    if (record_line_ == 0) return Status::Ok();
    for (char k : std::string("xywtgmlo"))
      if (seen_.find(k) == std::string::npos)
        return Status::InvalidArgument(name_ + ":" + std::to_string(record_line_) + ": " + record_ + ": field '" +
                                       std::string(1, k) + "' missing");
    return Status::Ok();
  }

  const CelestOptions& opt_;
  const std::string& name_;
  Header header_;
  std::vector<RawFrame> frames_;
  double scale_ = 0.01;
  int lineno_ = 0;
  bool in_records_ = false;
  int record_line_ = 0;
  std::string record_, seen_;
  RawFrame* current_ = nullptr;
  std::vector<long> x_;
};

}  // namespace

std::string CelestSummary::Report() const {
  std::string out = std::to_string(frames) + " frames, " + std::to_string(valid) + " valid";
  std::string why;
  for (auto [n, label] : {std::pair{lost, "lost"},
                          {missed, "missed"},
                          {overlapped, "overlapped"},
                          {no_centreline, "no centreline"},
                          {length_outliers, "length"},
                          {glitches, "glitch"}})
    if (n) why += (why.empty() ? "" : ", ") + std::to_string(n) + " " + label;
  if (!why.empty()) out += ", missing: " + why;
  out += "; " + std::to_string(swaps_fixed) + " head/tail swaps fixed; ";
  if (runs == 1) {
    out += "head from motion: ";
    out += runs_undecided ? "undecided (" + FormatFixed(travel, 2) + " body lengths), order as in the file"
                          : FormatFixed(travel, 2) + " body lengths head-first";
  } else {
    out += std::to_string(runs) + " runs (" + std::to_string(runs_flipped) + " flipped, " +
           std::to_string(runs_undecided) + " undecided)";
  }
  return out + "; body length " + FormatFixed(body_length_mm, 3) + " mm";
}

Result<CelestImport> ParseCelest(std::string_view text, const CelestOptions& opt, const std::string& name) {
  const CelestCalibration& cal = opt.calibration;
  if (!(cal.fps > 0) || !(cal.mm_per_px > 0))
    return Status::InvalidArgument(name + ": the frame rate and the scale (mm per pixel) must be positive");
  Parser parser(opt, name);
  WORMDRAG_RETURN_IF_ERROR(parser.Run(text));
  const std::vector<RawFrame>& raw = parser.frames();
  std::vector<Candidate> c = Classify(raw, opt);
  DropGlitches(c, opt);

  CelestImport out;
  CelestSummary& s = out.summary;
  s.frames = static_cast<int>(c.size());
  for (const Candidate& f : c) {
    s.valid += f.reason == Reason::kValid;
    s.lost += f.reason == Reason::kLost;
    s.missed += f.reason == Reason::kMissed;
    s.overlapped += f.reason == Reason::kOverlapped;
    s.no_centreline += f.reason == Reason::kNoCentreline;
    s.length_outliers += f.reason == Reason::kLength;
    s.glitches += f.reason == Reason::kGlitch;
  }
  const std::string worm = "worm " + std::to_string(opt.worm);
  if (s.valid == 0) {
    const std::string report = s.Report();
    return Status::InvalidArgument(name + ": " + worm + " has no valid frame (" + report.substr(0, report.find(';')) +
                                   ")");
  }
  OrderHeadTail(c, opt, &s);

  Kinematics& k = out.kinematics;
  k.fps = cal.fps;
  k.frames.resize(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    Frame& f = k.frames[i];
    f.t = i / cal.fps;
    if (c[i].reason != Reason::kValid) continue;
    const Points p = c[i].reversed ? Reversed(c[i].p) : c[i].p;
    for (int j = 0; j < kNumPoints; ++j) f.p[j] = p[j] * cal.mm_per_px;
    f.arc_length = c[i].length_px * cal.mm_per_px;
    f.valid = true;
  }
  s.body_length_mm = k.BodyLength();
  const std::string file = std::filesystem::path(name).filename().string();
  k.metadata["fps"] = FormatNumber(cal.fps, 10);
  k.metadata["units"] = "mm";
  k.metadata["source"] = "CeleST segmentation " + file + " " + worm;
  k.metadata["environment"] = "swimming (CeleST)";
  k.metadata["calibration"] = FormatNumber(cal.mm_per_px, 10) + " mm/px, " + FormatNumber(cal.fps, 10) + " fps (" +
                              cal.origin + ")";
  k.metadata["import"] = s.Report();
  return out;
}

Result<CelestImport> ReadCelest(const std::string& path, const CelestOptions& opt) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  return ParseCelest(*text, opt, path);
}

}  // namespace wormdrag
