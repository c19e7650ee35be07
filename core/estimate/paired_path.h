// The evaluation function of the paper (eq. 4) over a pair of recordings of worms
// in the same environment ("paired paths"):
//
//   E = mean over worms j, frames t ≤ t_max and evaluation points i of
//       ‖x_i^j(t) − r_i^j(t)‖   (measured vs simulated, mm)
//
// Missing frames are not scored (their joint angles are interpolated).
#pragma once

#include <array>
#include <functional>
#include <memory>
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
  bool restart_after_gaps = false;       // restart the simulated pose from the measured one after each gap
  Status Validate() const;
  std::string ToJson() const;            // canonical, for the eval key and the store
};

// One recording prepared for evaluation: its drive and, per scored frame, the
// measured evaluation points and their head-frame model positions.
struct ScoredRecording {
  std::string name;
  Kinematics kinematics;  // truncated to t_max
  ShapeDrive drive;
  PoseResets resets;
  struct ScoredFrame {
    int frame_offset;                       // index into Trajectory::poses
    std::vector<Vec2> measured;             // lab frame, per evaluation point
    std::vector<Vec2> model;                // head frame, per evaluation point
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
  int scored_count() const;  // (worm, frame, point) triples in the mean

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

// Per-thread buffers of an evaluation (no allocation after first use).
struct EvaluationWorkspace {
  SimWorkspace sim;
  Trajectory traj[kLanes];
};

// Residual vector of up to kLanes sets (see BatchEvaluator::EvaluateResiduals); a set
// that cannot be simulated gets an empty vector.
void ResidualLanes(const PairedPath& pair, const Coefficients* sets, int count, EvaluationWorkspace& ws,
                   std::vector<double>* out);

// The residuals of up to kLanes sets (as ResidualLanes) and their Jacobian with respect
// to (μ_n, μ_t, η_n, η_t), from the simulator's forward sensitivities: jacobian[i] is
// column-major, 4 columns of residuals[i].size() values (empty with the residuals).
void ResidualJacobianLanes(const PairedPath& pair, const Coefficients* sets, int count, EvaluationWorkspace& ws,
                           std::vector<double>* residuals, std::vector<double>* jacobian);

// The objective of up to kLanes sets, simulated against both worms.
void EvaluateLanes(const PairedPath& pair, const Coefficients* sets, int count, Objective objective,
                   EvaluationWorkspace& ws, double* out);

// Per-frame simulated and measured evaluation points (for reports and analyses).
struct PathComparison {
  std::array<std::vector<double>, 2> t;                        // per worm: frame times (scored frames)
  std::array<std::vector<std::vector<Vec2>>, 2> measured, simulated;  // [worm][frame][point]
  double e_mm = 0;
};
Result<PathComparison> ComparePaths(const PairedPath& pair, const Coefficients& c);

// Progress of a long evaluation: sets done of total.
using ProgressFn = std::function<void(int64_t done, int64_t total)>;

struct EvaluationRequest {
  int phase = 0;         // 1, 2, 3 (for the record); 0 = analysis evaluations
  Objective objective = Objective::kMeanDistance;
  bool reuse = true;     // may a stored earlier value of the same set be used
  ProgressFn progress;   // may be empty
};

// Evaluates many coefficient sets. The embedded implementation runs worker
// threads; the coordinator's sends tasks to workers; a caching one consults the store.
class BatchEvaluator {
 public:
  virtual ~BatchEvaluator() = default;
  // E (mm) of each set, +inf where the set cannot be simulated. Fails only when the
  // evaluation itself cannot go on (cancelled, store error, no workers …).
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
  // with respect to (μ_n, μ_t, η_n, η_t) (see ResidualJacobianLanes).
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

 private:
  std::shared_ptr<const PairedPath> pair_;
  int threads_;
  std::vector<EvaluationWorkspace> workspaces_;
};

// The number of hardware threads (≥ 1).
int DefaultThreads();

}  // namespace wormdrag
