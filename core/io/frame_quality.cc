#include "core/io/frame_quality.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/io/kinematics.h"

namespace wormdrag {
namespace {

std::vector<std::string> SplitComma(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

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
    const std::vector<std::string> cells = SplitComma(line);
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

}  // namespace wormdrag
