// The evaluation function of the paper (eq. 4) over a pair of recordings of worms
// in the same environment ("paired paths"):
//
//   E = mean over worms j, frames t ≤ t_max and evaluation points i of
//       ‖x_i^j(t) − r_i^j(t)‖   (measured vs simulated, mm)
//
// Missing frames are not scored (their joint angles are interpolated).
#pragma once

#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"
#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"
#include "core/sim/simulator.h"

namespace wormdrag {

struct EvaluationOptions {
  std::vector<int> points = {3, 7, 10};  // evaluation points: joint indices p_k, 0 … 13
  double t_max = 5.0;                    // analysed span from the first frame, s
  SimOptions sim;                        // solver (inertial), ε, Newton tolerance
  // Solver knots per frame interval; 0 = automatic: the fewest that give at least
  // `knot_rate` knots per second (2 at 300 fps, 20 at 30 fps for 600/s).
  int substeps = 0;
  double knot_rate = 600;
  int SubstepsFor(double fps) const;
  bool restart_after_gaps = false;  // restart the simulated pose from the measured one after each gap
  // The paper's swimming protocol: restart the simulated pose from the measured one
  // every `restart_every` seconds, so the path is scored over short stretches (a
  // swimmer that turns or drifts between them is not scored on it). 0 = never.
  double restart_every = 0;
  Status Validate() const;
  std::string ToJson() const;  // canonical, for the eval key and the store
};

// Refuses a recording whose analysed span (frames within t_max) would need more solver
// knots than a drive may hold (kMaxKnots), naming the file and its fps: the work and
// memory a recording implies are checked before any of it is allocated.
Status CheckRecordingWork(const Kinematics& full, const std::string& name, const EvaluationOptions& opt);

// One recording prepared for evaluation: its drive and, per scored frame, the
// measured evaluation points and their head-frame model positions.
struct ScoredRecording {
  std::string name;
  Kinematics kinematics;  // truncated to t_max
  ShapeDrive drive;
  PoseResets resets;
  struct ScoredFrame {
    int frame_offset;            // index into Trajectory::poses
    std::vector<Vec2> measured;  // lab frame, per evaluation point
    std::vector<Vec2> model;     // head frame, per evaluation point
  };
  std::vector<ScoredFrame> frames;
  double body_length() const { return drive.body().length; }
};

class PairedPath {
 public:
  // Validates and prepares the pair; `names` are used in messages.
  static Result<std::shared_ptr<const PairedPath>> Create(const std::array<Kinematics, 2>& recordings,
                                                          const std::array<std::string, 2>& names,
                                                          const EvaluationOptions& opt);
  const EvaluationOptions& options() const { return opt_; }
  const ScoredRecording& worm(int j) const { return worms_[j]; }
  double mean_body_length() const { return 0.5 * (worms_[0].body_length() + worms_[1].body_length()); }
  int scored_count() const;       // (worm, frame, point) triples in the mean
  int64_t knots_per_set() const;  // solver knots of one set against both worms

 private:
  EvaluationOptions opt_;
  std::array<ScoredRecording, 2> worms_;
};

// What an evaluation returns per set.
enum class Objective {
  kMeanDistance,         // E of the paper (mm): what is ranked, stored and reported
  kMeanSquaredDistance,  // mm²: smooth where E has a cone (vanishing residuals); Phase 3 descends on it
};

// Sums of distances and of squared distances for one simulated trajectory of one
// worm, or +inf when the run failed.
void DistanceSums(const ScoredRecording& w, const Trajectory& t, double* sum, double* sum_sq);

// Exact early abandoning (Phases 1–2; docs/decisions/0001-early-abandoning.md).
//
// A phase keeps its best `keep` sets. E is a sum of non-negative distances divided by
// their count, so a set whose partial sum already exceeds cut·count, where the cut is
// the keep-th smallest E of the phase known so far, ranks behind at least `keep` sets
// and cannot survive: its simulation stops and it gets kAbandoned instead of an E.
// The cut only tightens; which sets are abandoned depends on timing, the survivors and
// their E do not (a finished E is summed exactly as without abandoning).
inline constexpr double kAbandoned = std::numeric_limits<double>::quiet_NaN();
inline bool IsAbandoned(double e) {
  return std::isnan(e);
}

// The running cut of one phase, shared by every thread (and, through the coordinator,
// sent to workers with each task).
class RunningCut {
 public:
  // `keep`: how many sets the phase keeps; `start`: a cut already known (e.g. sent by
  // the coordinator), +inf if none.
  explicit RunningCut(int64_t keep, double start = std::numeric_limits<double>::infinity());
  int64_t keep() const { return keep_; }
  // +inf until `keep` exact E are known (or `start`); never grows.
  double value() const { return cut_.load(std::memory_order_relaxed); }
  // One exact E of a set of the phase, offered once per set (non-finite ones are ignored).
  void Offer(double e);

 private:
  int64_t keep_;
  std::mutex mu_;
  std::priority_queue<double> best_;  // the `keep` smallest offered E, the largest on top
  std::atomic<double> cut_;
};

// The smallest partial sum of distances (over `count` scored points) that proves
// E > cut, with the rounding of the final sum/count taken into account.
double AbandonThreshold(double cut, int count);

// Solver knots (time steps of one set against one worm), summed over sets: those
// simulated (see EvaluateLanes), and those a run without abandoning would simulate.
struct KnotCount {
  std::atomic<int64_t> simulated{0}, full{0};
};

// Per-thread buffers of an evaluation (no allocation after first use).
struct EvaluationWorkspace {
  SimWorkspace sim;
  Trajectory traj[kLanes];
};

// One worm's part of an evaluation of up to kLanes sets. The worms' simulations are
// independent, so a batch too small to give every thread its own sets runs its two
// worms on two threads (LocalEvaluator). Worm 0's part and worm 1's combine (CombineWorm*)
// in one order whichever thread ran them, so every value has the same bits either way.
enum class LaneOutput {
  kSums,       // distance sums (E and the mean squared distance)
  kResiduals,  // the residual vector
  kJacobians,  // the residual vector and its Jacobian
};
struct WormLanes {
  int64_t knots = 0;                             // knots simulated, summed over the sets
  double sum[kLanes] = {}, sum_sq[kLanes] = {};  // kSums (DistanceSums)
  bool failed[kLanes] = {};                      // kResiduals, kJacobians: the run failed
  std::vector<double> residuals[kLanes];         // this worm's rows
  std::vector<double> jacobian[kLanes];          // column-major, 4 columns of residuals[i].size()
};
void SimulateWormLanes(const PairedPath& pair, int worm, const Coefficients* sets, int count, LaneOutput what,
                       EvaluationWorkspace& ws, WormLanes* out);
// E (kMeanDistance) or the mean squared distance of each set from both worms' sums.
void CombineWormSums(const PairedPath& pair, const std::array<WormLanes, 2>& worms, int count, Objective objective,
                     double* out);
// Worm 0's rows, then worm 1's (empty when either run failed); jacobians may be null.
void CombineWormResiduals(const std::array<WormLanes, 2>& worms, int count, std::vector<double>* residuals,
                          std::vector<double>* jacobians);

// The objective of up to kLanes sets, simulated against both worms. With a cut (E
// only), a set whose partial sum proves E > cut->value() is stopped and gets
// kAbandoned; the batch ends when every set has an answer. Returns the knots
// simulated, summed over the sets: the lanes run in lock step, so a set counts every
// knot its batch advanced against each worm it was simulated against.
int64_t EvaluateLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                      EvaluationWorkspace& ws, double* out, const RunningCut* cut = nullptr);
// As above with one cut per set (cuts[i] for sets[i]; null: none at all) and for either
// objective: a set whose partial sum proves its objective above its own cut gets
// kAbandoned. Phase 3's scale-ray search gives each ray its own cut.
int64_t EvaluateLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                      EvaluationWorkspace& ws, double* out, const RunningCut* const* cuts);

// The same with the two worms on two threads (LocalEvaluator, for a batch too small to
// give each thread a chunk): each set is stopped once its sum against this worm alone
// proves it above its cut. sums[i] gets the worm's sum, kAbandoned or +inf (the run
// failed); CombineWormsAgainstCuts turns both worms' into what EvaluateLanes returns,
// bit for bit where a set has a value. Returns the knots simulated.
int64_t SimulateWormAgainstCuts(const PairedPath& pair, int worm, const Coefficients* sets, int count,
                                Objective objective, EvaluationWorkspace& ws, const RunningCut* const* cuts,
                                double* sums);
void CombineWormsAgainstCuts(const PairedPath& pair, const double* sums0, const double* sums1, int count, double* out);

// Per-frame simulated and measured evaluation points (for reports and analyses).
struct PathComparison {
  std::array<std::vector<double>, 2> t;                               // per worm: frame times (scored frames)
  std::array<std::vector<std::vector<Vec2>>, 2> measured, simulated;  // [worm][frame][point]
  double e_mm = 0;
};
Result<PathComparison> ComparePaths(const PairedPath& pair, const Coefficients& c);

// Progress of a long evaluation: sets done of total.
using ProgressFn = std::function<void(int64_t done, int64_t total)>;

struct EvaluationRequest {
  int phase = 0;  // 1, 2, 3 (for the record); 0 = analysis evaluations
  Objective objective = Objective::kMeanDistance;
  bool reuse = true;    // may a stored earlier value of the same set be used
  ProgressFn progress;  // may be empty
  // Phases 1–2: the phase's running cut (early abandoning), or null for exact E of
  // every set. Evaluators offer every exact E they produce or reuse to it, once per set.
  RunningCut* cut = nullptr;
  // Searches that need only the best set of each group (Phase 3's scale-ray search):
  // empty, or one cut per set (sets of a group share one, of keep 1), for either
  // objective. A set proven above its cut gets kAbandoned, and every exact value is
  // offered to its set's cut. An evaluator may ignore them and return exact values.
  std::vector<RunningCut*> set_cuts;
  KnotCount* knots = nullptr;  // may be null: where the simulated knots are counted
};

// InvalidArgument unless request.set_cuts is empty or holds one non-null cut per set.
Status CheckSetCuts(const std::vector<Coefficients>& sets, const EvaluationRequest& request);

// Evaluates many coefficient sets. The embedded implementation runs worker
// threads; the coordinator's sends tasks to workers; a caching one consults the store.
class BatchEvaluator {
 public:
  virtual ~BatchEvaluator() = default;
  // E (mm) of each set, +inf where the set cannot be simulated, kAbandoned where a
  // request's cut stopped it. Fails only when the evaluation itself cannot go on
  // (cancelled, store error, no workers …).
  virtual Status Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                          const EvaluationRequest& request = {}) = 0;
  // The residual vector of each set: (dx, dy) of every scored point of both worms,
  // divided by sqrt(count) so that its squared norm is the mean squared distance.
  // Least-squares methods (Phase 3) build their Gauss–Newton model from these.
  virtual Status EvaluateResiduals(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                                   const EvaluationRequest& request = {}) = 0;
  // Whether EvaluateResidualJacobians is available (exact derivatives, at about the
  // cost of one evaluation per set instead of a finite-difference stencil).
  virtual bool HasJacobians() const { return false; }
  // The residuals of each set (bit-identical to EvaluateResiduals) and their Jacobian
  // with respect to (μ_n, μ_t, η_n, η_t), from the simulator's forward sensitivities:
  // jacobians[i] column-major, 4 columns of residuals[i].size() values (empty with the
  // residuals when the set cannot be simulated).
  virtual Status EvaluateResidualJacobians(const std::vector<Coefficients>& sets,
                                           std::vector<std::vector<double>>* residuals,
                                           std::vector<std::vector<double>>* jacobians,
                                           const EvaluationRequest& request = {}) {
    return Status::Unimplemented("this evaluator has no Jacobians");
  }
  virtual int parallelism() const = 0;  // sets worth sending at once
};

// In-process evaluator: `threads` workers, each with its own SimWorkspace.
class LocalEvaluator : public BatchEvaluator {
 public:
  LocalEvaluator(std::shared_ptr<const PairedPath> pair, int threads);
  Status Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                  const EvaluationRequest& request = {}) override;
  Status EvaluateResiduals(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                           const EvaluationRequest& request = {}) override;
  bool HasJacobians() const override { return true; }
  Status EvaluateResidualJacobians(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                                   std::vector<std::vector<double>>* jacobians,
                                   const EvaluationRequest& request = {}) override;
  int parallelism() const override { return threads_ * kLanes; }
  const PairedPath& pair() const { return *pair_; }
  // One worm's share of every chunk of kLanes sets (chunks[c] holds sets c·kLanes…),
  // chunks on this evaluator's threads: a service worker's part of a call split by worm.
  void EvaluateWorm(const std::vector<Coefficients>& sets, int worm, LaneOutput what, std::vector<WormLanes>* chunks);

 private:
  // Evaluate with EvaluationRequest::set_cuts; count_knots(knots, sets) per chunk.
  void EvaluateAgainstSetCuts(const std::vector<Coefficients>& sets, std::vector<double>* e,
                              const EvaluationRequest& request, const std::function<void(int64_t, int)>& count_knots);

  std::shared_ptr<const PairedPath> pair_;
  int threads_;
  std::vector<EvaluationWorkspace> workspaces_;
};

// The number of hardware threads (≥ 1).
int DefaultThreads();

}  // namespace wormdrag
