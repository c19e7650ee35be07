#include "core/estimate/paired_path.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <thread>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Result<ScoredRecording> Prepare(const Kinematics& full, const std::string& name, const EvaluationOptions& opt) {
  ScoredRecording w;
  w.name = name;
  if (full.Duration() + 0.5 / full.fps < opt.t_max) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s: the recording is %.4g s long, shorter than t_max = %.4g s", name.c_str(),
                  full.Duration(), opt.t_max);
    return Status::InvalidArgument(buf);
  }
  WORMDRAG_RETURN_IF_ERROR(CheckRecordingWork(full, name, opt));
  w.kinematics = full.Truncated(opt.t_max);
  BodyModel body;
  body.length = w.kinematics.BodyLength();
  if (!(body.length > 0)) return Status::InvalidArgument(name + ": no valid frame within t_max");
  auto drive = ShapeDrive::Build(w.kinematics, body, {opt.SubstepsFor(full.fps)});
  if (!drive.ok()) return drive.status().Annotate(name);
  w.drive = std::move(*drive);
  const auto& frames = w.kinematics.frames;
  bool in_gap = false;
  const double t0 = frames[w.drive.first_frame()].t;
  int stretch = 0;
  for (int f = w.drive.first_frame(); f <= w.drive.last_frame(); ++f) {
    if (!frames[f].valid) {
      in_gap = true;
      continue;
    }
    const int s = opt.restart_every > 0 ? static_cast<int>(std::floor((frames[f].t - t0) / opt.restart_every + 1e-9))
                                        : 0;
    if ((in_gap && opt.restart_after_gaps) || s > stretch) w.resets.frames.push_back(f);
    stretch = s;
    in_gap = false;
    ScoredRecording::ScoredFrame sf;
    sf.frame_offset = f - w.drive.first_frame();
    const Points model = HeadFramePoints(w.drive.FrameShape(f), body.link_length());
    for (int p : opt.points) {
      sf.measured.push_back(frames[f].p[p]);
      sf.model.push_back(model[p]);
    }
    w.frames.push_back(std::move(sf));
  }
  return w;
}

}  // namespace

int EvaluationOptions::SubstepsFor(double fps) const {
  if (substeps > 0) return substeps;
  // Capped so that a tiny or absurd fps cannot overflow the int; any step past
  // kMaxKnots is refused by CheckRecordingWork anyway.
  const double n = std::ceil(knot_rate / fps - 1e-9);
  if (!(n < static_cast<double>(kMaxKnots))) return static_cast<int>(kMaxKnots);
  return std::max(1, static_cast<int>(n));
}

Status CheckRecordingWork(const Kinematics& full, const std::string& name, const EvaluationOptions& opt) {
  if (!(full.fps > 0) || !std::isfinite(full.fps))
    return Status::InvalidArgument(name + ": fps must be a positive number");
  if (full.frames.empty()) return Status::InvalidArgument(name + ": no frames");
  // Frames from the first to the last valid one within t_max: what ShapeDrive builds.
  const double t0 = full.frames.front().t, slack = 0.5 / full.fps;
  int64_t first = -1, last = -1;
  for (size_t f = 0; f < full.frames.size() && full.frames[f].t - t0 <= opt.t_max + slack; ++f)
    if (full.frames[f].valid) {
      if (first < 0) first = static_cast<int64_t>(f);
      last = static_cast<int64_t>(f);
    }
  if (first < 0) return Status::Ok();  // Prepare names the missing frames
  const int substeps = opt.SubstepsFor(full.fps);
  const int64_t knots = KnotCountFor(last - first + 1, substeps);
  if (knots <= kMaxKnots) return Status::Ok();
  char rate[64];
  if (opt.substeps > 0)
    std::snprintf(rate, sizeof rate, "the step");
  else
    std::snprintf(rate, sizeof rate, "knot rate %.4g/s", opt.knot_rate);
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "%s: fps %.6g asks for %d solver knots per frame (%s); the %lld frames within t_max = %.4g s need "
                "%lld knots, at most %lld are allowed: check the file's '# fps' (or lower --t-max)",
                name.c_str(), full.fps, substeps, rate, static_cast<long long>(last - first + 1), opt.t_max,
                static_cast<long long>(knots), static_cast<long long>(kMaxKnots));
  return Status::InvalidArgument(buf);
}

Status EvaluationOptions::Validate() const {
  if (points.empty()) return Status::InvalidArgument("points: at least one evaluation point is needed");
  for (int p : points)
    if (p < 0 || p > kNumLinks)
      return Status::InvalidArgument("points: " + std::to_string(p) + " is not a point index 0 … " +
                                     std::to_string(kNumLinks));
  if (!(t_max > 0) || !std::isfinite(t_max))
    return Status::InvalidArgument("t_max must be a positive number of seconds");
  if (substeps < 0 || substeps > 1000)
    return Status::InvalidArgument("step (knots per frame) must be between 1 and 1000, or 0 for automatic");
  if (!(restart_every >= 0) || !std::isfinite(restart_every))
    return Status::InvalidArgument("restart_every must be a non-negative number of seconds (0 = never)");
  if (substeps == 0 && !(knot_rate >= 1 && knot_rate <= 1e6))
    return Status::InvalidArgument("knot rate must be between 1 and 1e6 knots per second");
  return sim.Validate();
}

// Canonical key text, not a document for reading: evaluation keys and the job store
// compare it as text to reuse evaluations, so its bytes (%.17g numbers, this key order)
// are fixed.
std::string EvaluationOptions::ToJson() const {
  std::string pts;
  for (size_t i = 0; i < points.size(); ++i) pts += (i ? "," : "") + std::to_string(points[i]);
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "{\"points\":[%s],\"t_max\":%.17g,\"solver\":\"%s\",\"eps\":%.17g,\"tolerance\":%.17g,"
                "\"substeps\":%d,\"knot_rate\":%.17g,\"restart_after_gaps\":%s}",
                pts.c_str(), t_max, SolverName(sim.solver), sim.epsilon, sim.velocity_tolerance, substeps, knot_rate,
                restart_after_gaps ? "true" : "false");
  std::string s = buf;
  // Absent when off, so the evaluation keys of jobs without it keep their form.
  if (restart_every > 0) {
    s.pop_back();
    char r[64];
    std::snprintf(r, sizeof r, ",\"restart_every\":%.17g}", restart_every);
    s += r;
  }
  return s;
}

Result<std::shared_ptr<const PairedPath>> PairedPath::Create(const std::array<Kinematics, 2>& recordings,
                                                             const std::array<std::string, 2>& names,
                                                             const EvaluationOptions& opt) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  auto p = std::make_shared<PairedPath>();
  p->opt_ = opt;
  for (int j = 0; j < 2; ++j) {
    auto w = Prepare(recordings[j], names[j], opt);
    if (!w.ok()) return w.status();
    if (w->frames.empty()) return Status::InvalidArgument(names[j] + ": no valid frame to score within t_max");
    p->worms_[j] = std::move(*w);
  }
  // Both worms share one body model up to the length of each; lengths that differ
  // by more than 2× mean different units or different animals, not one environment.
  const double l0 = p->worms_[0].body_length(), l1 = p->worms_[1].body_length();
  if (std::max(l0, l1) > 2.0 * std::min(l0, l1)) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the pair has different body models: %s is %.4g mm long, %s %.4g mm (check the units)",
                  names[0].c_str(), l0, names[1].c_str(), l1);
    return Status::InvalidArgument(buf);
  }
  return std::shared_ptr<const PairedPath>(std::move(p));
}

int PairedPath::scored_count() const {
  int n = 0;
  for (const auto& w : worms_) n += static_cast<int>(w.frames.size() * opt_.points.size());
  return n;
}

int64_t PairedPath::knots_per_set() const {
  return static_cast<int64_t>(worms_[0].drive.knots().size() + worms_[1].drive.knots().size());
}

namespace {

// The distances of one scored frame, added to the sums. Never inlined: the
// frame-by-frame sums of early abandoning and the whole-trajectory sums run this one
// piece of machine code, so a set's E has the same bits either way (inlined copies may
// contract multiply-adds differently).
[[gnu::noinline]] void AddFrameDistances(const ScoredRecording::ScoredFrame& f, const Pose& g, double* sum,
                                         double* sum_sq) {
  const double c = std::cos(g.q0), s = std::sin(g.q0);
  for (size_t i = 0; i < f.model.size(); ++i) {
    const Vec2& m = f.model[i];
    const double dx = g.x + c * m.x() - s * m.y() - f.measured[i].x();
    const double dy = g.y + s * m.x() + c * m.y() - f.measured[i].y();
    const double d2 = dx * dx + dy * dy;
    *sum += std::sqrt(d2);
    *sum_sq += d2;
  }
}

// Sums the distances of the live lanes frame by frame while one worm is simulated and
// stops the lanes whose partial sum proves the objective above their cut: the sum of
// distances for E, of squared distances for the mean squared distance. `base[l]` is
// lane l's sum over the worms already simulated; lanes outside `lanes` are stopped at
// once; cuts[l] is lane l's cut.
class AbandoningWatch : public FrameObserver {
 public:
  AbandoningWatch(const ScoredRecording& w, const Trajectory* traj, unsigned lanes, const double* base,
                  const RunningCut* const* cuts, Objective objective, int scored)
      : w_(w),
        traj_(traj),
        lanes_(lanes),
        base_(base),
        cuts_(cuts),
        squared_(objective != Objective::kMeanDistance),
        scored_(scored) {
    std::fill_n(cut_seen_, kLanes, kInf);
    std::fill_n(threshold_, kLanes, kInf);
  }
  unsigned Frame(int frame_offset, unsigned live) override {
    live &= lanes_;
    if (next_ == w_.frames.size() || w_.frames[next_].frame_offset != frame_offset) return live;
    const ScoredRecording::ScoredFrame& f = w_.frames[next_++];
    for (int l = 0; l < kLanes; ++l)
      if ((live >> l) & 1u) AddFrameDistances(f, traj_[l].poses[frame_offset], &sum[l], &sum_sq[l]);
    // Sums of non-negative terms only grow, and so does their rounded total with the
    // worms before: base + partial ≤ the finished sum.
    for (int l = 0; l < kLanes; ++l) {
      if (!((live >> l) & 1u)) continue;
      const double c = cuts_[l]->value();
      if (c != cut_seen_[l]) {
        cut_seen_[l] = c;
        threshold_[l] = AbandonThreshold(c, scored_);
      }
      if (base_[l] + (squared_ ? sum_sq[l] : sum[l]) > threshold_[l]) live &= ~(1u << l);
    }
    return live;
  }
  // The objective's partial sum of lane l.
  double partial(int l) const { return squared_ ? sum_sq[l] : sum[l]; }
  double sum[kLanes] = {}, sum_sq[kLanes] = {};

 private:
  const ScoredRecording& w_;
  const Trajectory* traj_;
  unsigned lanes_;
  const double* base_;
  const RunningCut* const* cuts_;
  bool squared_;
  int scored_;
  size_t next_ = 0;                              // the next scored frame
  double cut_seen_[kLanes], threshold_[kLanes];  // per lane: the cut last read, and its threshold
};

// Simulates the lanes in `*open` against worm j, each stopped once base[l] plus its
// partial sum proves it above its cut. A lane stopped (out = kAbandoned) or whose run
// failed (out = +inf, as DistanceSums) leaves *open; the others get the worm's sum in
// sum[l] (`sum` and `out` may be one array). Returns the knots simulated.
int64_t AbandoningWorm(const PairedPath& pair, int j, const Coefficients* sets, int count, Objective objective,
                       EvaluationWorkspace& ws, const double* base, const RunningCut* const* cuts, unsigned* open,
                       double* sum, double* out) {
  const ScoredRecording& w = pair.worm(j);
  AbandoningWatch watch(w, ws.traj, *open, base, cuts, objective, pair.scored_count());
  Simulator::SimulateBatch(w.drive, sets, count, pair.options().sim, &w.resets, ws.sim, ws.traj, &watch);
  const int64_t knots = ws.traj[0].summary.knots * __builtin_popcount(*open);
  for (int l = 0; l < count; ++l) {
    if (!((*open >> l) & 1u)) continue;
    const Trajectory& t = ws.traj[l];
    if (t.summary.stopped) {
      out[l] = kAbandoned;
      *open &= ~(1u << l);
    } else if (!t.summary.ok() || !std::isfinite(watch.partial(l))) {
      out[l] = kInf;
      *open &= ~(1u << l);
    } else {
      sum[l] = watch.partial(l);
    }
  }
  return knots;
}

// EvaluateLanes with cuts: worm by worm, each set stopped as soon as it is proven out.
int64_t AbandoningLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                        EvaluationWorkspace& ws, double* out, const RunningCut* const* cuts) {
  double total[kLanes] = {}, sum[kLanes];
  unsigned open = (1u << count) - 1u;  // lanes without an answer yet
  int64_t knots = 0;
  for (int j = 0; j < 2 && open != 0; ++j) {
    knots += AbandoningWorm(pair, j, sets, count, objective, ws, total, cuts, &open, sum, out);
    for (int l = 0; l < count; ++l)
      if ((open >> l) & 1u) total[l] += sum[l];
  }
  const double n = pair.scored_count();
  for (int l = 0; l < count; ++l)
    if ((open >> l) & 1u) out[l] = total[l] / n;
  return knots;
}

// EvaluateLanes without a cut: every set simulated to its end against both worms.
int64_t WholeLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                   EvaluationWorkspace& ws, double* out) {
  std::array<WormLanes, 2> worms;
  for (int j = 0; j < 2; ++j) SimulateWormLanes(pair, j, sets, count, LaneOutput::kSums, ws, &worms[j]);
  CombineWormSums(pair, worms, count, objective, out);
  return worms[0].knots + worms[1].knots;
}

}  // namespace

void DistanceSums(const ScoredRecording& w, const Trajectory& t, double* sum_out, double* sum_sq_out) {
  if (!t.summary.ok()) {
    *sum_out = *sum_sq_out = kInf;
    return;
  }
  double sum = 0, sum_sq = 0;
  for (const auto& f : w.frames) AddFrameDistances(f, t.poses[f.frame_offset], &sum, &sum_sq);
  *sum_out = std::isfinite(sum) ? sum : kInf;
  *sum_sq_out = std::isfinite(sum_sq) ? sum_sq : kInf;
}

RunningCut::RunningCut(int64_t keep, double start) : keep_(std::max<int64_t>(1, keep)), cut_(start) {}

void RunningCut::Offer(double e) {
  // An E at or above the cut cannot lower it (nor can it ever matter later).
  if (!std::isfinite(e) || !(e < value())) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (static_cast<int64_t>(best_.size()) < keep_) {
    best_.push(e);
  } else if (e < best_.top()) {
    best_.pop();
    best_.push(e);
  } else {
    return;
  }
  if (static_cast<int64_t>(best_.size()) == keep_ && best_.top() < cut_.load(std::memory_order_relaxed))
    cut_.store(best_.top(), std::memory_order_relaxed);
}

double AbandonThreshold(double cut, int count) {
  if (!(cut < kInf)) return kInf;
  // A sum S > T ≥ next(cut)·count (exactly) gives S/count > next(cut), so the rounded
  // E = fl(S/count) ≥ next(cut) > cut: rounding is monotone. T is the product rounded
  // and then moved up one ulp, which puts it at or above the exact product.
  const double up = std::nextafter(cut, kInf);
  return std::nextafter(up * count, kInf);
}

int64_t EvaluateLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                      EvaluationWorkspace& ws, double* out, const RunningCut* cut) {
  if (!cut || objective != Objective::kMeanDistance) return WholeLanes(pair, sets, count, objective, ws, out);
  const RunningCut* cuts[kLanes];
  std::fill(cuts, cuts + kLanes, cut);
  return AbandoningLanes(pair, sets, count, objective, ws, out, cuts);
}

int64_t EvaluateLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                      EvaluationWorkspace& ws, double* out, const RunningCut* const* cuts) {
  if (!cuts) return WholeLanes(pair, sets, count, objective, ws, out);
  return AbandoningLanes(pair, sets, count, objective, ws, out, cuts);
}

Status CheckSetCuts(const std::vector<Coefficients>& sets, const EvaluationRequest& request) {
  if (request.set_cuts.empty()) return Status::Ok();
  if (request.set_cuts.size() != sets.size())
    return Status::InvalidArgument("an evaluation of " + std::to_string(sets.size()) + " sets has " +
                                   std::to_string(request.set_cuts.size()) + " set cuts");
  for (const RunningCut* c : request.set_cuts)
    if (!c) return Status::InvalidArgument("an evaluation's set cuts include a null cut");
  return Status::Ok();
}

int64_t SimulateWormAgainstCuts(const PairedPath& pair, int worm, const Coefficients* sets, int count,
                                Objective objective, EvaluationWorkspace& ws, const RunningCut* const* cuts,
                                double* sums) {
  const double zero[kLanes] = {};
  unsigned open = (1u << count) - 1u;
  // Each lane gets either its sum or its verdict, so both go to `sums`.
  return AbandoningWorm(pair, worm, sets, count, objective, ws, zero, cuts, &open, sums, sums);
}

void CombineWormsAgainstCuts(const PairedPath& pair, const double* sums0, const double* sums1, int count, double* out) {
  const double n = pair.scored_count();
  for (int l = 0; l < count; ++l) {
    if (IsAbandoned(sums0[l]) || IsAbandoned(sums1[l]))
      out[l] = kAbandoned;  // as AbandoningLanes, which never runs worm 1 for a set worm 0 stopped
    else if (!std::isfinite(sums0[l]) || !std::isfinite(sums1[l]))
      out[l] = kInf;
    else
      out[l] = (0.0 + sums0[l] + sums1[l]) / n;  // summed as AbandoningLanes sums
  }
}

Result<PathComparison> ComparePaths(const PairedPath& pair, const Coefficients& c) {
  PathComparison out;
  double sum = 0;
  for (int j = 0; j < 2; ++j) {
    const ScoredRecording& w = pair.worm(j);
    const Trajectory t = Simulator::Simulate(w.drive, c, pair.options().sim, &w.resets);
    if (!t.summary.ok())
      return Status::FailedPrecondition("coefficients " + c.ToString() + ": " + t.summary.OneLineReport());
    for (const auto& f : w.frames) {
      const Pose& g = t.poses[f.frame_offset];
      const double cs = std::cos(g.q0), sn = std::sin(g.q0);
      std::vector<Vec2> sim;
      for (size_t i = 0; i < f.model.size(); ++i) {
        const Vec2& m = f.model[i];
        sim.emplace_back(g.x + cs * m.x() - sn * m.y(), g.y + sn * m.x() + cs * m.y());
        sum += (sim.back() - f.measured[i]).norm();
      }
      out.t[j].push_back(w.kinematics.frames[w.drive.first_frame() + f.frame_offset].t);
      out.measured[j].push_back(f.measured);
      out.simulated[j].push_back(std::move(sim));
    }
  }
  out.e_mm = sum / pair.scored_count();
  return out;
}

int DefaultThreads() {
  return std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace wormdrag
