#include "core/io/pose_csv.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "core/common/format.h"

namespace wormdrag {
namespace {

struct Line {
  int number = 0;  // 1-based, in the file
  std::vector<std::string> cells;
};

// One CSV line; quotes as pandas writes them ("a,b" and "" for a quote).
std::vector<std::string> SplitCells(std::string_view s) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quoted && c == '"' && i + 1 < s.size() && s[i + 1] == '"') {
      out.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

std::vector<Line> SplitLines(std::string_view text) {
  std::vector<Line> lines;
  int number = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(pos, end - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    ++number;
    if (l.find_first_not_of(" \t") != std::string_view::npos) lines.push_back({number, SplitCells(l)});
    pos = end + 1;
  }
  return lines;
}

// A whole cell as a number ("nan" included).
bool ToNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return *end == '\0';
}

bool ToFrame(const std::string& s, long* f) {
  double v = 0;
  if (!ToNumber(s, &v) || !(v >= 0) || v != std::floor(v) || v > 1e9) return false;
  *f = static_cast<long>(v);
  return true;
}

bool AllNumbers(const std::vector<std::string>& cells) {
  double v;
  return std::all_of(cells.begin(), cells.end(), [&](const std::string& c) { return ToNumber(c, &v); });
}

struct Point {
  std::string name;
  int x = -1, y = -1, p = -1;  // columns; p = likelihood / score, −1 = none
};

// Where the numbers are: the result of reading a layout's header.
struct Plan {
  std::string layout;
  size_t header_lines = 0;
  size_t columns = 0;  // cells per data row
  int frame_col = -1;  // −1: frames numbered by row
  int track_col = -1;  // SLEAP: rows of other tracks are skipped
  std::string individual;
  std::vector<Point> points;
};

std::string List(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "'" : ", '") + x + "'";
  return s;
}

// The individual (track) to import among `found` (first-appearance order).
Result<std::string> Choose(const std::vector<std::string>& found, const std::string& wanted, const std::string& where,
                           const char* what) {
  if (wanted.empty()) {
    if (found.size() <= 1) return found.empty() ? std::string() : found.front();
    return Status::InvalidArgument(where + ": " + std::to_string(found.size()) + " " + what + "s (" + List(found) +
                                   "); choose one with --id");
  }
  if (std::find(found.begin(), found.end(), wanted) == found.end())
    return Status::InvalidArgument(where + ": no " + what + " '" + wanted + "'; the file has " +
                                   (found.empty() ? std::string("none") : List(found)));
  return wanted;
}

Result<Plan> PlanDeepLabCut(const std::vector<Line>& lines, const PoseCsvOptions& opt, const std::string& name) {
  Plan plan;
  std::map<std::string, const Line*> level;
  for (const Line& l : lines) {
    const std::string& key = l.cells[0];
    if (key != "scorer" && key != "individuals" && key != "bodyparts" && key != "coords") break;
    level[key] = &l;
    ++plan.header_lines;
    if (key == "coords") break;
  }
  if (!level.count("bodyparts") || !level.count("coords"))
    return Status::InvalidArgument(name + ":" + std::to_string(lines.front().number) +
                                   ": a DeepLabCut header needs the rows scorer, bodyparts and coords");
  const Line& coords = *level["coords"];
  plan.columns = coords.cells.size();
  for (const auto& [key, l] : level)
    if (l->cells.size() != plan.columns)
      return Status::InvalidArgument(name + ":" + std::to_string(l->number) + ": " + std::to_string(l->cells.size()) +
                                     " cells in row '" + key + "', expected " + std::to_string(plan.columns));
  size_t first = 1;  // index columns: one (frame) or three (labelled images)
  auto is_coord = [](const std::string& c) { return c == "x" || c == "y" || c == "likelihood"; };
  while (first < plan.columns && !is_coord(coords.cells[first])) ++first;
  if (first == plan.columns)
    return Status::InvalidArgument(name + ":" + std::to_string(coords.number) + ": no x, y columns in row 'coords'");
  const Line* ind = level.count("individuals") ? level["individuals"] : nullptr;
  std::vector<std::pair<std::string, Point>> parts;  // (individual, body part) in column order
  std::vector<std::string> individuals;
  for (size_t j = first; j < plan.columns; ++j) {
    const std::string who = ind ? ind->cells[j] : "", part = level["bodyparts"]->cells[j], c = coords.cells[j];
    if (!is_coord(c))
      return Status::InvalidArgument(name + ":" + std::to_string(coords.number) + ": column " + std::to_string(j + 1) +
                                     ": coords '" + c + "', expected x, y or likelihood");
    auto it = std::find_if(parts.begin(), parts.end(),
                           [&](const auto& p) { return p.first == who && p.second.name == part; });
    if (it == parts.end()) it = parts.insert(parts.end(), {who, Point{part}});
    (c == "x" ? it->second.x : c == "y" ? it->second.y : it->second.p) = static_cast<int>(j);
    if (who != "single" && std::find(individuals.begin(), individuals.end(), who) == individuals.end())
      individuals.push_back(who);
  }
  auto chosen = Choose(ind ? individuals : std::vector<std::string>{}, opt.individual,
                       name + ":" + std::to_string(ind ? ind->number : coords.number), "individual");
  if (!chosen.ok()) return chosen.status();
  plan.individual = *chosen;
  for (const auto& [who, pt] : parts) {
    if (who != plan.individual) continue;
    if (pt.x < 0 || pt.y < 0)
      return Status::InvalidArgument(name + ":" + std::to_string(coords.number) + ": body part '" + pt.name +
                                     "' has no " + (pt.x < 0 ? "x" : "y") + " column");
    plan.points.push_back(pt);
  }
  plan.layout = ind ? "multi-animal DeepLabCut" : "DeepLabCut";
  // A single index column holds the video frame number; labelled images are numbered by row.
  plan.frame_col = first == 1 ? 0 : -1;
  for (size_t i = plan.header_lines; i < lines.size() && plan.frame_col == 0; ++i) {
    long f;
    if (!ToFrame(lines[i].cells[0], &f)) plan.frame_col = -1;
  }
  return plan;
}

Result<Plan> PlanSleap(const std::vector<Line>& lines, const PoseCsvOptions& opt, const std::string& name) {
  Plan plan;
  plan.layout = "SLEAP";
  plan.header_lines = 1;
  const std::vector<std::string>& h = lines.front().cells;
  plan.columns = h.size();
  auto col = [&](const std::string& c) {
    auto it = std::find(h.begin(), h.end(), c);
    return it == h.end() ? -1 : static_cast<int>(it - h.begin());
  };
  plan.frame_col = col("frame_idx");
  plan.track_col = col("track");
  for (const std::string& c : h) {
    if (c.size() < 3 || c.compare(c.size() - 2, 2, ".x") != 0) continue;
    Point pt{c.substr(0, c.size() - 2), col(c), col(c.substr(0, c.size() - 2) + ".y"),
             col(c.substr(0, c.size() - 2) + ".score")};
    if (pt.y < 0)
      return Status::InvalidArgument(name + ":" + std::to_string(lines.front().number) + ": node '" + pt.name +
                                     "' has no column '" + pt.name + ".y'");
    plan.points.push_back(pt);
  }
  std::vector<std::string> tracks;
  for (size_t i = 1; i < lines.size() && plan.track_col >= 0; ++i) {
    const auto& cells = lines[i].cells;
    if (cells.size() == plan.columns && !cells[plan.track_col].empty() &&
        std::find(tracks.begin(), tracks.end(), cells[plan.track_col]) == tracks.end())
      tracks.push_back(cells[plan.track_col]);
  }
  auto chosen = Choose(tracks, opt.individual, name, "track");
  if (!chosen.ok()) return chosen.status();
  plan.individual = *chosen;
  return plan;
}

Result<Plan> PlanPlain(const std::vector<Line>& lines, const std::string& name) {
  Plan plan;
  plan.layout = "plain";
  const Line& first = lines.front();
  plan.columns = first.cells.size();
  const bool header = !AllNumbers(first.cells);
  plan.header_lines = header ? 1 : 0;
  size_t start = 0;
  if (header && (first.cells[0] == "frame" || first.cells[0] == "frame_idx")) plan.frame_col = 0, start = 1;
  if ((plan.columns - start) % 2 != 0)
    return Status::InvalidArgument(name + ":" + std::to_string(first.number) + ": " +
                                   std::to_string(plan.columns - start) + " coordinate columns, expected x, y pairs");
  for (size_t k = 0; start + 2 * k < plan.columns; ++k) {
    const int x = static_cast<int>(start + 2 * k);
    for (int c : {x, x + 1}) {
      const std::string want = (c == x ? "x" : "y") + std::to_string(k);
      if (header && first.cells[c] != want)
        return Status::InvalidArgument(name + ":" + std::to_string(first.number) + ": column " + std::to_string(c + 1) +
                                       " '" + first.cells[c] + "', expected '" + want + "'");
    }
    plan.points.push_back({std::to_string(k), x, x + 1});
  }
  return plan;
}

enum class Kind { kUnknown, kDeepLabCut, kSleap, kPlain };

// The layout a header line (the first line) starts.
Kind Classify(const std::vector<std::string>& h) {
  if (h[0] == "scorer") return Kind::kDeepLabCut;
  const bool has_x = std::any_of(
      h.begin(), h.end(), [](const std::string& c) { return c.size() > 2 && c.compare(c.size() - 2, 2, ".x") == 0; });
  if (has_x && std::find(h.begin(), h.end(), "frame_idx") != h.end()) return Kind::kSleap;
  if (h[0] == "x0" || ((h[0] == "frame" || h[0] == "frame_idx") && h.size() > 1 && h[1] == "x0")) return Kind::kPlain;
  return h.size() >= 6 && AllNumbers(h) ? Kind::kPlain : Kind::kUnknown;
}

enum class Reason { kValid, kUndetected, kLowLikelihood };

struct Sample {
  long frame = 0;
  int line = 0;
  Reason reason = Reason::kValid;
  std::vector<Vec2> px;
};

Result<std::vector<Sample>> ReadSamples(const std::vector<Line>& lines, const Plan& plan, const PoseCsvOptions& opt,
                                        const std::string& name) {
  std::vector<Sample> out;
  long row = 0;
  for (size_t i = plan.header_lines; i < lines.size(); ++i) {
    const Line& l = lines[i];
    const std::string at = name + ":" + std::to_string(l.number);
    if (l.cells.size() != plan.columns)
      return Status::InvalidArgument(at + ": " + std::to_string(l.cells.size()) + " cells, expected " +
                                     std::to_string(plan.columns));
    if (plan.track_col >= 0 && l.cells[plan.track_col] != plan.individual) continue;
    Sample s;
    s.line = l.number;
    s.frame = row++;
    if (plan.frame_col >= 0 && !ToFrame(l.cells[plan.frame_col], &s.frame))
      return Status::InvalidArgument(at + ": column " + std::to_string(plan.frame_col + 1) + ": not a frame number '" +
                                     l.cells[plan.frame_col] + "'");
    for (const Point& pt : plan.points) {
      double v[3] = {0, 0, 1};
      const int cols[3] = {pt.x, pt.y, pt.p};
      for (int c = 0; c < 3; ++c) {
        if (cols[c] < 0) continue;
        const std::string& cell = l.cells[cols[c]];
        if (cell.empty() || (ToNumber(cell, &v[c]) && std::isnan(v[c]))) {
          if (c < 2) s.reason = Reason::kUndetected;
          v[c] = c < 2 ? NAN : 1;  // a point without a likelihood is judged by its coordinates
        } else if (!ToNumber(cell, &v[c])) {
          return Status::InvalidArgument(at + ": column " + std::to_string(cols[c] + 1) + " (" + pt.name + " " +
                                         (c == 0   ? "x"
                                          : c == 1 ? "y"
                                                   : "likelihood") +
                                         "): not a number '" + cell + "'");
        }
      }
      if (s.reason == Reason::kValid && v[2] < opt.min_likelihood) s.reason = Reason::kLowLikelihood;
      s.px.emplace_back(v[0], v[1]);
    }
    out.push_back(std::move(s));
  }
  std::stable_sort(out.begin(), out.end(), [](const Sample& a, const Sample& b) { return a.frame < b.frame; });
  for (size_t i = 1; i < out.size(); ++i)
    if (out[i].frame == out[i - 1].frame)
      return Status::InvalidArgument(name + ":" + std::to_string(out[i].line) + ": frame " +
                                     std::to_string(out[i].frame) + " appears twice (also on line " +
                                     std::to_string(out[i - 1].line) + ")");
  return out;
}

}  // namespace

std::string PoseCsvSummary::Report(double min_likelihood) const {
  std::string r = layout + (individual.empty() ? "" : " '" + individual + "'") + ": " +
                  std::to_string(bodyparts.size()) + " body parts";
  if (!bodyparts.empty()) r += " (" + bodyparts.front() + " … " + bodyparts.back() + ")";
  r += "; " + std::to_string(frames) + " frames, " + std::to_string(valid) + " valid";
  std::string miss;
  auto add = [&](int n, const std::string& what) {
    if (n) miss += (miss.empty() ? "" : ", ") + std::to_string(n) + " " + what;
  };
  add(absent, "absent");
  add(undetected, "undetected");
  add(low_likelihood, "likelihood < " + FormatNumber(min_likelihood, 10));
  return miss.empty() ? r : r + ", missing: " + miss;
}

bool LooksLikePoseCsv(std::string_view first_line) {
  if (!first_line.empty() && first_line.back() == '\r') first_line.remove_suffix(1);
  return Classify(SplitCells(first_line)) != Kind::kUnknown;
}

Result<PoseCsvImport> ParsePoseCsv(std::string_view text, const PoseCsvOptions& opt, const std::string& name) {
  if (!(opt.fps > 0) || !(opt.um_per_px > 0))
    return Status::InvalidArgument(name +
                                   ": a pose CSV holds pixels and frame numbers only: give --fps and --um-per-px");
  const std::vector<Line> lines = SplitLines(text);
  if (lines.empty()) return Status::InvalidArgument(name + ": empty file");
  Result<Plan> plan = Status::InvalidArgument(
      name + ":" + std::to_string(lines.front().number) +
      ": not a pose CSV: expected a DeepLabCut header (scorer, bodyparts, coords), a SLEAP header (track, frame_idx, "
      "<node>.x, …), x0,y0,… columns or rows of numbers");
  switch (Classify(lines.front().cells)) {
    case Kind::kDeepLabCut:
      plan = PlanDeepLabCut(lines, opt, name);
      break;
    case Kind::kSleap:
      plan = PlanSleap(lines, opt, name);
      break;
    case Kind::kPlain:
      plan = PlanPlain(lines, name);
      break;
    case Kind::kUnknown:
      break;
  }
  if (!plan.ok()) return plan.status();
  if (plan->points.size() < 3)
    return Status::InvalidArgument(name + ": " + std::to_string(plan->points.size()) +
                                   " body parts; a skeleton needs at least 3, head → tail");
  auto samples = ReadSamples(lines, *plan, opt, name);
  if (!samples.ok()) return samples.status();
  if (samples->empty()) return Status::InvalidArgument(name + ": no data rows");

  PoseCsvImport out;
  PoseCsvSummary& s = out.summary;
  s.layout = plan->layout;
  s.individual = plan->individual;
  for (const Point& p : plan->points) s.bodyparts.push_back(p.name);
  Kinematics& k = out.kinematics;
  k.fps = opt.fps;
  const long f0 = samples->front().frame;
  k.frames.resize(samples->back().frame - f0 + 1);
  for (size_t i = 0; i < k.frames.size(); ++i) k.frames[i].t = (f0 + static_cast<double>(i)) / opt.fps;
  s.frames = static_cast<int>(k.frames.size());
  s.absent = s.frames - static_cast<int>(samples->size());
  for (const Sample& smp : *samples) {
    s.undetected += smp.reason == Reason::kUndetected;
    s.low_likelihood += smp.reason == Reason::kLowLikelihood;
    if (smp.reason != Reason::kValid) continue;
    std::vector<Vec2> line;
    for (const Vec2& p : smp.px) line.push_back(p * opt.um_per_px / 1000.0);  // px → mm
    auto pts = ResampleByArcLength(line);
    if (!pts.ok()) {
      ++s.undetected;  // all points on one spot
      continue;
    }
    Frame& f = k.frames[smp.frame - f0];
    f.p = *pts;
    f.arc_length = ArcLength(line);
    f.valid = true;
    ++s.valid;
  }
  if (s.valid == 0) return Status::InvalidArgument(name + ": no valid frame (" + s.Report(opt.min_likelihood) + ")");
  std::string parts;
  for (const std::string& b : s.bodyparts) parts += (parts.empty() ? "" : " ") + b;
  k.metadata["fps"] = FormatNumber(opt.fps, 10);
  k.metadata["units"] = "mm";
  k.metadata["source"] = s.layout + " CSV " + std::filesystem::path(name).filename().string() +
                         (s.individual.empty() ? "" : " '" + s.individual + "'");
  k.metadata["calibration"] = FormatNumber(opt.um_per_px, 10) + " µm/px, " + FormatNumber(opt.fps, 10) + " fps";
  k.metadata["bodyparts"] = parts;
  k.metadata["import"] = s.Report(opt.min_likelihood);
  return out;
}

Result<PoseCsvImport> ReadPoseCsv(const std::string& path, const PoseCsvOptions& opt) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  return ParsePoseCsv(*text, opt, path);
}

}  // namespace wormdrag
