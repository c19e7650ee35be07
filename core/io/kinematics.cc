#include "core/io/kinematics.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace wormdrag {
namespace {

std::string Trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> SplitCells(std::string_view line) {
  std::vector<std::string> cells;
  size_t start = 0;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      cells.push_back(Trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return cells;
}

bool IsMissingCell(const std::string& c) {
  return c.empty() || c == "nan" || c == "NaN" || c == "NAN" || c == "-nan";
}

bool ParseNumber(const std::string& c, double* out) {
  if (c.empty()) return false;
  char* end = nullptr;
  errno = 0;
  *out = std::strtod(c.c_str(), &end);
  return end != c.c_str() && *end == '\0' && errno != ERANGE && std::isfinite(*out);
}

std::string Where(const std::string& name, int line) {
  return name + ":" + std::to_string(line) + ": ";
}

// Column name of cell index j of a data row: "t", "x0", "y0", …
std::string ColumnName(size_t j) {
  if (j == 0) return "t";
  return std::string((j - 1) % 2 == 0 ? "x" : "y") + std::to_string((j - 1) / 2);
}

// The factor from the file's `# units` to mm.
Status LengthScale(const std::map<std::string, std::string>& metadata, const std::string& name, double* scale) {
  const auto u = metadata.find("units");
  const std::string units = u == metadata.end() ? "mm" : u->second;
  if (units == "mm") {
    *scale = 1.0;
  } else if (units == "um" || units == "µm") {
    *scale = 1e-3;
  } else if (units == "px") {
    const auto p = metadata.find("px_per_mm");
    double ppm = 0;
    if (p == metadata.end() || !ParseNumber(p->second, &ppm) || ppm <= 0)
      return Status::InvalidArgument(name +
                                     ": units 'px' need a positive '# px_per_mm: <value>' (an uncalibrated "
                                     "`wormdrag track` output: re-run it with --um-per-px, or add that line)");
    *scale = 1.0 / ppm;
  } else {
    return Status::InvalidArgument(name + ": unknown units '" + units + "' (expected mm, um or px)");
  }
  return Status::Ok();
}

// The missing frames of `run`, appended to `frames` in order; `run` is emptied.
void AppendMissing(std::vector<double>* run, std::vector<Frame>* frames) {
  for (double t : *run) {
    Frame f;
    f.t = t;
    frames->push_back(f);
  }
  run->clear();
}

Status NoPointsWithin(const std::string& name, int line, double span, double t0) {
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "column 2 (x0): no row within %.6g s of the first (t = %.6g) has points; an estimate analyses "
                "only that span (its t_max) and needs a frame with points there",
                span, t0);
  return Status::InvalidArgument(Where(name, line) + buf);
}

}  // namespace

double ArcLength(const std::vector<Vec2>& polyline) {
  double s = 0;
  for (size_t i = 1; i < polyline.size(); ++i) s += (polyline[i] - polyline[i - 1]).norm();
  return s;
}

Result<Points> ResampleByArcLength(const std::vector<Vec2>& pl) {
  if (pl.size() < 3)
    return Status::InvalidArgument("a skeleton needs at least 3 points, got " + std::to_string(pl.size()));
  std::vector<double> s(pl.size(), 0.0);
  for (size_t i = 1; i < pl.size(); ++i) s[i] = s[i - 1] + (pl[i] - pl[i - 1]).norm();
  const double total = s.back();
  if (!(total > 0)) return Status::InvalidArgument("a skeleton has zero length (all points coincide)");
  Points out;
  size_t seg = 1;
  for (int k = 0; k < kNumPoints; ++k) {
    const double target = total * k / kNumLinks;
    if (k == 0) {
      out[k] = pl.front();
      continue;
    }
    if (k == kNumLinks) {
      out[k] = pl.back();
      continue;
    }
    while (seg < pl.size() - 1 && s[seg] < target) ++seg;
    const double len = s[seg] - s[seg - 1];
    const double a = len > 0 ? (target - s[seg - 1]) / len : 0.0;
    out[k] = pl[seg - 1] + a * (pl[seg] - pl[seg - 1]);
  }
  return out;
}

double Kinematics::BodyLength() const {
  double sum = 0;
  int n = 0;
  for (const Frame& f : frames)
    if (f.valid) {
      sum += f.arc_length;
      ++n;
    }
  return n ? sum / n : 0.0;
}

int Kinematics::NumValid() const {
  int n = 0;
  for (const Frame& f : frames) n += f.valid;
  return n;
}

Kinematics Kinematics::Truncated(double t_max) const {
  Kinematics k;
  k.fps = fps;
  k.metadata = metadata;
  if (frames.empty()) return k;
  const double t0 = frames.front().t;
  // Half a frame of slack so that t_max = 5 s keeps the frame at exactly 5 s.
  const double slack = fps > 0 ? 0.5 / fps : 1e-9;
  for (const Frame& f : frames)
    if (f.t - t0 <= t_max + slack) k.frames.push_back(f);
  return k;
}

namespace {

// The kinematics CSV (docs/conventions.md §6), line by line: metadata comments, the
// header row, then one row per frame.
class KinematicsCsvReader {
 public:
  KinematicsCsvReader(const std::string& name, const KinematicsLimits& limits) : name_(name), limits_(limits) {}

  // One trimmed, non-empty line.
  Status Line(const std::string& line, int lineno) {
    if (line[0] == '#') return Metadata(line, lineno);
    if (!have_header_) return Header(line, lineno);
    return Row(line, lineno);
  }

  Result<Kinematics> Finish() {
    if (!have_header_) return Status::InvalidArgument(name_ + ": no header row 't,x0,y0,…' found");
    if (k_.frames.empty() && missing_run_.empty())
      return Status::InvalidArgument(name_ + ": no frames after the header");
    if (k_.frames.empty())
      return Status::InvalidArgument(name_ + ": every frame is missing: none of the " +
                                     std::to_string(missing_run_.size()) + " rows after the header (line " +
                                     std::to_string(header_line_) + ") has a number in every column x0 … " +
                                     ColumnName(ncols_ - 1));
    AppendMissing(&missing_run_, &k_.frames);
    k_.metadata["units"] = "mm";  // converted on reading
    k_.metadata.erase("px_per_mm");
    return std::move(k_);
  }

 private:
  Status Metadata(const std::string& line, int lineno) {
    if (have_header_) return Status::InvalidArgument(Where(name_, lineno) + "metadata line after the header row");
    const size_t colon = line.find(':');
    if (colon == std::string::npos) return Status::Ok();  // a plain comment
    const std::string key = Trim(std::string_view(line).substr(1, colon - 1));
    k_.metadata[key] = Trim(std::string_view(line).substr(colon + 1));
    return Status::Ok();
  }

  // t,x0,y0,...,xM,yM; the metadata is complete once it arrives.
  Status Header(const std::string& line, int lineno) {
    const auto cells = SplitCells(line);
    if (cells.empty() || cells[0] != "t")
      return Status::InvalidArgument(Where(name_, lineno) + "header must start with 't', got '" + cells[0] + "'");
    if (cells.size() < 7 || (cells.size() - 1) % 2 != 0)
      return Status::InvalidArgument(Where(name_, lineno) + "header needs t and x,y pairs for at least 3 points, got " +
                                     std::to_string(cells.size()) + " columns");
    for (size_t j = 1; j < cells.size(); ++j)
      if (cells[j] != ColumnName(j))
        return Status::InvalidArgument(Where(name_, lineno) + "column " + std::to_string(j + 1) + ": expected '" +
                                       ColumnName(j) + "', got '" + cells[j] + "'");
    ncols_ = cells.size();
    have_header_ = true;
    header_line_ = lineno;
    auto it = k_.metadata.find("fps");
    if (it == k_.metadata.end())
      return Status::InvalidArgument(name_ + ": missing required metadata '# fps: <frames per second>'");
    if (!ParseNumber(it->second, &k_.fps) || k_.fps <= 0)
      return Status::InvalidArgument(name_ + ": metadata fps must be a positive number, got '" + it->second + "'");
    return LengthScale(k_.metadata, name_, &scale_);
  }

  Status Row(const std::string& line, int lineno) {
    const size_t rows = k_.frames.size() + missing_run_.size();
    if (rows >= static_cast<size_t>(kMaxFrames))
      return Status::InvalidArgument(Where(name_, lineno) + "more than " + std::to_string(kMaxFrames) +
                                     " frames; a recording may have at most that many");
    const auto cells = SplitCells(line);
    Frame f;
    if (!ParseNumber(cells[0], &f.t))
      return Status::InvalidArgument(Where(name_, lineno) + "column 1 (t): not a number '" + cells[0] + "'");
    const double previous = missing_run_.empty() ? (rows ? k_.frames.back().t : 0.0) : missing_run_.back();
    if (rows > 0 && !(f.t > previous))
      return Status::InvalidArgument(Where(name_, lineno) + "column 1 (t): time " + cells[0] +
                                     " does not increase (previous frame at " + std::to_string(previous) + ")");
    if (rows == 0) t0_ = f.t;
    if (k_.frames.empty() && f.t - t0_ > limits_.points_within + 0.5 / k_.fps)
      return NoPointsWithin(name_, lineno, limits_.points_within, t0_);
    if (cells.size() == 1) {  // a time with no points: missing frame
      missing_run_.push_back(f.t);
      return Status::Ok();
    }
    if (cells.size() != ncols_)
      return Status::InvalidArgument(Where(name_, lineno) + "expected " + std::to_string(ncols_) + " columns, got " +
                                     std::to_string(cells.size()));
    bool missing = false;
    poly_.assign((ncols_ - 1) / 2, Vec2::Zero());
    for (size_t j = 1; j < ncols_; ++j) {
      double v;
      if (IsMissingCell(cells[j])) {
        missing = true;
        continue;
      }
      if (!ParseNumber(cells[j], &v))
        return Status::InvalidArgument(Where(name_, lineno) + "column " + std::to_string(j + 1) + " (" + ColumnName(j) +
                                       "): not a number '" + cells[j] + "'");
      poly_[(j - 1) / 2][(j - 1) % 2] = v * scale_;
    }
    if (missing) {
      missing_run_.push_back(f.t);
      return Status::Ok();
    }
    auto r = ResampleByArcLength(poly_);
    if (!r.ok()) return r.status().Annotate(Where(name_, lineno).substr(0, Where(name_, lineno).size() - 2));
    f.p = *r;
    f.arc_length = ArcLength(poly_);
    f.valid = true;
    AppendMissing(&missing_run_, &k_.frames);
    k_.frames.push_back(f);
    return Status::Ok();
  }

  const std::string& name_;
  const KinematicsLimits& limits_;
  Kinematics k_;
  double scale_ = 1.0;  // to mm
  bool have_header_ = false;
  size_t ncols_ = 0;
  int header_line_ = 0;
  double t0_ = 0;
  // Times of the missing frames since the last frame with points: a missing frame is
  // 8 bytes here and ~250 as a Frame, so a file of time-only rows is refused without
  // ever being built (a 10 MB file of them would otherwise hold ~300 MB of frames).
  std::vector<double> missing_run_;
  std::vector<Vec2> poly_;
};

}  // namespace

Result<Kinematics> ParseKinematics(std::string_view text, const std::string& name, const KinematicsLimits& limits) {
  KinematicsCsvReader reader(name, limits);
  int lineno = 0;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view raw = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++lineno;
    if (lineno == 1 && raw.size() >= 3 && raw.substr(0, 3) == "\xEF\xBB\xBF") raw.remove_prefix(3);  // BOM
    const std::string line = Trim(raw);
    if (line.empty()) {
      if (nl == text.size()) break;
      continue;
    }
    WORMDRAG_RETURN_IF_ERROR(reader.Line(line, lineno));
  }
  return reader.Finish();
}

Result<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": cannot open for reading");
  // A regular file is read into a string of its size: one copy of it in memory, where
  // a stringstream would hold up to three while it grows and is copied out.
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  if (size > 0 && in) {
    std::string text(static_cast<size_t>(size), '\0');
    in.read(text.data(), size);
    if (in.gcount() == size && in.peek() == std::char_traits<char>::eof()) return text;
    in.clear();
    in.seekg(0, std::ios::beg);
  }
  in.clear();
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return Status::Internal(path + ": read error");
  return ss.str();
}

Result<Kinematics> ReadKinematics(const std::string& path) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  return ParseKinematics(*text, path);
}

std::string FormatKinematics(const Kinematics& k) {
  std::string out;
  char buf[64];
  std::snprintf(buf, sizeof buf, "# fps: %.10g\n", k.fps);
  out += buf;
  // Lengths are mm, except in uncalibrated video tracks (units px, scale unknown): the
  // file says so, and reading it back asks for the scale instead of taking pixels as mm.
  const auto u = k.metadata.find("units");
  const bool px = u != k.metadata.end() && u->second == "px";
  out += px ? "# units: px\n" : "# units: mm\n";
  for (const auto& [key, value] : k.metadata)
    if (key != "fps" && key != "units" && (px || key != "px_per_mm")) out += "# " + key + ": " + value + "\n";
  out += "t";
  for (int i = 0; i < kNumPoints; ++i) out += ",x" + std::to_string(i) + ",y" + std::to_string(i);
  out += "\n";
  for (const Frame& f : k.frames) {
    std::snprintf(buf, sizeof buf, "%.10g", f.t);
    out += buf;
    for (int i = 0; i < kNumPoints; ++i) {
      if (f.valid) {
        std::snprintf(buf, sizeof buf, ",%.12g,%.12g", f.p[i].x(), f.p[i].y());
        out += buf;
      } else {
        out += ",nan,nan";
      }
    }
    out += "\n";
  }
  return out;
}

Status WriteFileAtomically(const std::string& path, const std::string& contents) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::InvalidArgument(path + ": cannot open for writing");
    out << contents;
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      return Status::Internal(path + ": write failed");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return Status::Internal(path + ": cannot move the written file into place");
  }
  return Status::Ok();
}

Status WriteKinematics(const Kinematics& k, const std::string& path) {
  return WriteFileAtomically(path, FormatKinematics(k));
}

}  // namespace wormdrag
