#include "core/io/tierpsy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>

#include "core/common/format.h"
#include "core/io/hdf5_file.h"
#include "core/io/internal/tierpsy_source.h"
#include "core/io/tierpsy_stage.h"

namespace wormdrag {
namespace {

using tierpsy_internal::Detect;
using tierpsy_internal::kStageGroup;
using tierpsy_internal::kTable;
using tierpsy_internal::Layout;
using tierpsy_internal::ResolveCalibration;
using tierpsy_internal::Source;

// Skeleton rows read at once: bounds the memory for long recordings.
constexpr long kBlockRows = 4096;
// A longer span of timestamps (over 20 days at 25 fps) is a corrupt table, not a recording.
constexpr long kMaxFrames = 50'000'000;

enum class Reason { kValid, kNoSkeleton, kRejected, kStageMoving };

struct Row {
  long time = 0;   // timestamp: frame index on the file's time base
  long frame = 0;  // video frame number (index of /stage_position_pix)
  long sid = -1;   // row in the skeleton dataset, −1 = none
  Reason reason = Reason::kValid;
  bool interpolated = false;
  Vec2 offset = Vec2::Zero();  // stage position, µm
};

std::string WormList(const std::map<long, int>& worms) {
  std::string s;
  int n = 0;
  for (const auto& w : worms) {
    if (++n > 30) return s + ", … (" + std::to_string(worms.size()) + " worms)";
    s += (s.empty() ? "" : ", ") + std::to_string(w.first);
  }
  return s;
}

// The rows of the chosen worm, sorted by time, one per timestamp (the first, as Tierpsy).
Result<std::vector<Row>> ReadWormRows(const h5::File& f, const std::string& skel_ds, uint64_t n_skeletons,
                                      TierpsyOptions opt, TierpsySummary* s) {
  const std::string where = f.path() + ": " + kTable;
  auto columns = f.Columns(kTable);
  if (!columns.ok()) return columns.status();
  auto has = [&](const char* c) { return std::find(columns->begin(), columns->end(), c) != columns->end(); };
  auto read = [&](const char* c) -> Result<std::vector<double>> {
    return has(c) ? f.ReadColumn(kTable, c) : std::vector<double>{};
  };
  auto worm = f.ReadColumn(kTable, "worm_index_joined");
  if (!worm.ok()) return worm.status();
  auto sid = f.ReadColumn(kTable, "skeleton_id");
  if (!sid.ok()) return sid.status();
  std::map<long, int> worms;
  for (double w : *worm) ++worms[std::lround(w)];
  if (opt.worm < 0) {
    if (worms.size() != 1)
      return Status::InvalidArgument(where + ": " +
                                     (worms.empty() ? std::string("no worms")
                                                    : std::to_string(worms.size()) + " worms (worm_index_joined " +
                                                          WormList(worms) + "); choose one with --worm"));
    opt.worm = worms.begin()->first;
  } else if (!worms.count(opt.worm)) {
    return Status::InvalidArgument(where + ": no worm with worm_index_joined " + std::to_string(opt.worm) +
                                   "; the file has " + WormList(worms));
  }
  s->worm = opt.worm;
  Result<std::vector<double>> ts = read("timestamp_raw"), fn = read("frame_number"), has_skel = read("has_skeleton"),
                              good = read("is_good_skel"), skeletonized = read("was_skeletonized");
  for (const auto* r : {&ts, &fn, &has_skel, &good, &skeletonized})
    if (!r->ok()) return r->status();
  std::vector<size_t> mine;
  for (size_t r = 0; r < worm->size(); ++r)
    if (std::lround((*worm)[r]) == opt.worm) mine.push_back(r);
  // Tierpsy uses timestamp_raw unless one is NaN (no video timestamps); then frame_number.
  bool use_ts = !ts->empty();
  for (size_t r : mine) use_ts = use_ts && std::isfinite((*ts)[r]);
  if (!use_ts && fn->empty())
    return Status::InvalidArgument(where + ": no column gives the frames of worm " + std::to_string(opt.worm) +
                                   " (timestamp_raw missing or NaN, no frame_number)");
  std::vector<Row> rows;
  for (size_t r : mine) {
    Row row;
    row.time = std::lround(use_ts ? (*ts)[r] : (*fn)[r]);
    row.frame = fn->empty() ? row.time : std::lround((*fn)[r]);
    row.sid = std::lround((*sid)[r]);
    if (row.sid >= static_cast<long>(n_skeletons))
      return Status::InvalidArgument(where + ": row " + std::to_string(r) + ": skeleton_id " + std::to_string(row.sid) +
                                     " beyond " + skel_ds + " (" + std::to_string(n_skeletons) + " rows)");
    if (row.sid < 0 || (!has_skel->empty() && (*has_skel)[r] == 0))
      row.reason = Reason::kNoSkeleton;
    else if (!good->empty() && (*good)[r] == 0)
      row.reason = Reason::kRejected;
    row.interpolated = !skeletonized->empty() && (*skeletonized)[r] == 0;
    rows.push_back(row);
  }
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.time < b.time; });
  rows.erase(std::unique(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.time == b.time; }),
             rows.end());
  return rows;
}

// Adds a stage offset (µm) to a row; without one (NaN: the stage moved) the frame is missing.
void SetOffset(Row& r, const Vec2& offset) {
  if (offset.allFinite())
    r.offset = offset;
  else if (r.reason == Reason::kValid)
    r.reason = Reason::kStageMoving;
}

Status ApplyStage(const h5::File& f, const Source& src, const TierpsyOptions& opt, double um_per_px,
                  std::vector<Row>& rows, TierpsySummary* s) {
  if (src.layout == Layout::kFeaturesN) {
    if (!opt.stage_file.empty() || !opt.use_stage)
      return Status::InvalidArgument(f.path() +
                                     ": --stage and --no-stage apply to *_skeletons.hdf5 files; "
                                     "featuresN positions are on the plate already");
    double wt2 = 0;
    if (f.HasAttribute(kTable, "is_WT2")) {
      auto v = f.NumericAttribute(kTable, "is_WT2");
      if (v.ok()) wt2 = v->front();
    }
    s->stage = wt2 ? "corrected by Tierpsy (is_WT2)" : "fixed camera (plate coordinates)";
    return Status::Ok();
  }
  if (src.layout == Layout::kWormPose) {
    s->stage = "none: per-frame crops, positions are not on the plate";
    return Status::Ok();
  }
  if (!opt.use_stage) {
    s->stage = "ignored (--no-stage): image coordinates";
    return Status::Ok();
  }
  if (f.Has(kStageGroup)) {
    auto by_time = ReadStageAlignment(f);
    if (!by_time.ok()) return by_time.status();
    for (Row& r : rows) {
      auto it = by_time->find(r.time);
      SetOffset(r, it == by_time->end() ? Vec2(NAN, NAN) : it->second);
    }
    s->stage = "from " + std::string(kStageGroup);
    return Status::Ok();
  }
  std::optional<h5::File> masked;  // Tierpsy's masked video, holding /stage_position_pix
  if (!opt.stage_file.empty()) {
    auto m = h5::File::Open(opt.stage_file);
    if (!m.ok()) return m.status();
    masked.emplace(std::move(*m));
  } else if (!f.IsDataset("/stage_position_pix")) {
    s->stage = "none (no " + std::string(kStageGroup) + "): image coordinates";
    return Status::Ok();
  }
  const h5::File& from = masked ? *masked : f;
  auto pos = ReadStagePositionPix(from);
  if (!pos.ok()) return pos.status();
  for (Row& r : rows) {
    if (r.frame < 0 || r.frame >= static_cast<long>(pos->size()))
      return Status::InvalidArgument(from.path() + ": /stage_position_pix: " + std::to_string(pos->size()) +
                                     " frames, but worm " + std::to_string(s->worm) + " has frame_number " +
                                     std::to_string(r.frame));
    SetOffset(r, (*pos)[r.frame] * um_per_px);
  }
  s->stage = "from /stage_position_pix of " + std::filesystem::path(from.path()).filename().string();
  return Status::Ok();
}

// Puts the rows on the frame grid of their timestamps and reads the skeletons of the
// valid ones, a block of skeleton rows at a time, scaled to mm and moved by the stage
// offset; NaN or zero-length skeletons make their frames missing.
Status FillFrames(const h5::File& f, const std::string& ds, int n_points, double um_per_px,
                  const std::vector<Row>& rows, Kinematics& k, TierpsySummary* s) {
  const long t0 = rows.front().time, span = rows.back().time - t0 + 1;
  if (span > kMaxFrames)
    return Status::InvalidArgument(f.path() + ": " + kTable + ": the timestamps of worm " + std::to_string(s->worm) +
                                   " span " + std::to_string(span) + " frames");
  k.frames.resize(span);
  for (long i = 0; i < span; ++i) k.frames[i].t = static_cast<double>(t0 + i) / k.fps;
  s->frames = static_cast<int>(span);
  s->dropped = s->frames - static_cast<int>(rows.size());
  std::vector<const Row*> todo;
  for (const Row& r : rows) {
    s->no_skeleton += r.reason == Reason::kNoSkeleton;
    s->rejected += r.reason == Reason::kRejected;
    s->stage_moving += r.reason == Reason::kStageMoving;
    if (r.reason == Reason::kValid) todo.push_back(&r);
  }
  std::sort(todo.begin(), todo.end(), [](const Row* a, const Row* b) { return a->sid < b->sid; });
  const double scale = um_per_px > 0 ? um_per_px : 1.0;  // 0: in µm already
  for (size_t a = 0; a < todo.size();) {
    size_t b = a;
    while (b < todo.size() && todo[b]->sid - todo[a]->sid < kBlockRows) ++b;
    const long first = todo[a]->sid;
    auto block = f.ReadRows(ds, first, todo[b - 1]->sid - first + 1);
    if (!block.ok()) return block.status();
    for (; a < b; ++a) {
      const Row& r = *todo[a];
      const double* xy = block->data() + (r.sid - first) * n_points * 2;
      std::vector<Vec2> line(n_points);
      bool finite = true;
      for (int j = 0; j < n_points; ++j) {
        line[j] = (Vec2(xy[2 * j], xy[2 * j + 1]) * scale + r.offset) / 1000.0;  // µm → mm
        finite = finite && line[j].allFinite();
      }
      auto p = finite ? ResampleByArcLength(line) : Result<Points>(Status::InvalidArgument("NaN"));
      if (!p.ok()) {
        ++s->no_skeleton;
        continue;
      }
      Frame& fr = k.frames[r.time - t0];
      fr.p = *p;
      fr.arc_length = ArcLength(line);
      fr.valid = true;
      ++s->valid;
      s->interpolated += r.interpolated;
    }
  }
  return Status::Ok();
}

}  // namespace

std::string TierpsySummary::Report() const {
  std::string r = layout + (worm >= 0 ? " worm " + std::to_string(worm) : "") + ": " + std::to_string(frames) +
                  " frames, " + std::to_string(valid) + " valid";
  std::string miss;
  auto add = [&](int n, const char* what) {
    if (n) miss += (miss.empty() ? "" : ", ") + std::to_string(n) + " " + what;
  };
  add(no_skeleton, "no skeleton");
  add(rejected, "rejected by Tierpsy's filter");
  add(stage_moving, "stage moving");
  add(dropped, "dropped");
  if (!miss.empty()) r += ", missing: " + miss;
  if (interpolated) r += "; " + std::to_string(interpolated) + " interpolated by Tierpsy";
  return r + "; " + std::to_string(points) + " points; calibration " + calibration + "; stage " + stage;
}

Result<TierpsyImport> ReadTierpsy(const std::string& path, const TierpsyOptions& opt) {
  auto opened = h5::File::Open(path);
  if (!opened.ok()) return opened.status();
  const h5::File& f = *opened;
  auto src = Detect(f);
  if (!src.ok()) return src.status();
  auto shape = f.Shape(src->skeletons);
  if (!shape.ok()) return shape.status();
  if (shape->size() != 3 || (*shape)[2] != 2 || (*shape)[1] < 3) {
    std::string d;
    for (uint64_t v : *shape) d += (d.empty() ? "" : ", ") + std::to_string(v);
    return Status::InvalidArgument(path + ": " + src->skeletons + ": shape (" + d +
                                   "), expected (skeletons, points ≥ 3, 2)");
  }
  const uint64_t n_skel = (*shape)[0];
  const int n_points = static_cast<int>((*shape)[1]);
  TierpsyImport out;
  TierpsySummary& s = out.summary;
  s.layout = src->name;
  s.points = n_points;
  std::vector<Row> rows;
  if (src->layout == Layout::kWormPose) {
    if (opt.worm >= 0) return Status::InvalidArgument(path + ": a WormPose file holds one worm; drop --worm");
    for (long i = 0; i < static_cast<long>(n_skel); ++i) rows.push_back({i, i, i});
  } else {
    auto r = ReadWormRows(f, src->skeletons, n_skel, opt, &s);
    if (!r.ok()) return r.status();
    rows = std::move(*r);
  }
  if (rows.empty()) return Status::InvalidArgument(path + ": " + src->skeletons + ": no skeletons");
  auto cal = ResolveCalibration(f, *src, opt);
  if (!cal.ok()) return cal.status();
  s.calibration = cal->text;
  Status st = ApplyStage(f, *src, opt, cal->um_per_px, rows, &s);
  if (!st.ok()) return st;

  Kinematics& k = out.kinematics;
  k.fps = cal->fps;
  Status filled = FillFrames(f, src->skeletons, n_points, cal->um_per_px, rows, k, &s);
  if (!filled.ok()) return filled;
  if (s.valid == 0) return Status::InvalidArgument(path + ": no valid skeleton (" + s.Report() + ")");
  const std::string file = std::filesystem::path(path).filename().string();
  k.metadata["fps"] = FormatNumber(cal->fps, 10);
  k.metadata["units"] = "mm";
  k.metadata["source"] = "Tierpsy " + s.layout + " " + file + (s.worm >= 0 ? " worm " + std::to_string(s.worm) : "");
  k.metadata["calibration"] = s.calibration;
  k.metadata["stage"] = s.stage;
  k.metadata["import"] = s.Report();
  return out;
}

}  // namespace wormdrag
