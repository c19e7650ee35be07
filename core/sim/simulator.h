// The body-dynamics simulator (docs/conventions.md §2). Joint angles are prescribed; the unknown
// is the rigid motion of the chain, ξ = (V_x, V_y, ω) in the head frame.
//
//  quasi-static: at every instant ξ minimises the convex dissipation potential
//      Φ(ξ) = Σ_k Σ_d μ_d (sqrt(v_{k,d}² + ε²) − ε) + ½ η_d v_{k,d}²,
//    so ξ depends on the shape only and the pose follows by quadrature on SE(2).
//  inertial: the body-frame momentum π = M̂(q) ξ + ŝ(q, q̇) obeys the Euler–Poincaré
//    equations of SE(2), π̇ = ad*_ξ π + F(ξ), integrated with variable-step BDF2
//    (L-stable: the paper's link mass makes the system very stiff). Each step is the
//    same convex minimisation with a kinetic term ½ ξᵀ(M̂/β)ξ added.
//
// Both solve for ξ at the knots of a ShapeDrive with a primal-dual Newton method
// (Chan–Golub–Mulet): the dual variables λ = sgnε(v) are carried from knot to knot,
// which keeps Newton fast when Coulomb friction pins link velocities near zero; a
// damped primal Newton method takes over if it ever fails to converge. The pose is
// then integrated knot to knot with classical RK4, the mid-interval ξ coming from a
// cubic through the neighbouring knots (4th order in the knot spacing).
//
// The kernel advances kLanes coefficient sets in lock step against one ShapeDrive
// (SIMD across sets); a SimWorkspace holds every buffer, so a thread simulates any
// number of sets without allocating after its first use. Every lane's result depends
// on its own coefficient set only (not on the sets beside it, nor on lanes stopped
// early), bit for bit: callers may group sets into batches in any order.
//
// Forward sensitivities (SimulateBatchWithSensitivities, sensitivity.cc) give the
// derivative of every pose with respect to the four coefficients c. At each knot ξ
// is a stationary point of the knot objective, ∇Φ(ξ; c, history) = 0, so by the
// implicit function theorem dξ/dc = H⁻¹ (∂c_hist/∂c − ∂(∇Φ_friction)/∂c), H the
// Hessian at the solution (the inertial history's sensitivities are carried from
// knot to knot); the pose sensitivities follow by differentiating the RK4 step.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"

namespace wormdrag {

enum class Solver { kInertial, kQuasiStatic };
const char* SolverName(Solver s);
Result<Solver> ParseSolver(const std::string& name);

struct SimOptions {
  Solver solver = Solver::kInertial;  // the paper's model
  double epsilon = kDefaultEpsilon;   // smooth-sign width, mm/s
  double velocity_tolerance = 1e-8;   // Newton stops when the step in V (and ω·L) is below this, mm/s
  int max_iterations = 40;            // primal-dual iterations before the damped fallback
  bool record_velocities = false;     // keep ξ at every knot in Trajectory::knot_velocities
  Status Validate() const;
};

inline constexpr int kLanes = 8;  // coefficient sets per SIMD batch

// Per-run statistics: why a run is not trustworthy, and what the solver did.
struct SimSummary {
  std::string singular;        // non-empty: the quasi-static problem has no unique solution
  long knots = 0;              // velocity solves
  long newton_iterations = 0;  // summed over knots (for this lane's batch)
  long fallbacks = 0;          // knots of this lane that needed the damped primal Newton method
  long unconverged = 0;        // knots of this lane where even that did not meet the tolerance
  bool stopped = false;        // a FrameObserver stopped the lane: its poses end early
  bool ok() const { return singular.empty() && unconverged == 0 && !stopped; }
  std::string OneLineReport() const;
};

// d(x, y, q0)/d(μ_n, μ_t, η_n, η_t) of one pose: [pose component][coefficient].
using PoseSensitivity = std::array<std::array<double, 4>, 3>;

struct Trajectory {
  int first_frame = 0;                                 // index of poses[0] in the recording's frames
  std::vector<Pose> poses;                             // one per frame first_frame … last valid frame
  std::vector<PoseSensitivity> sensitivities;          // per pose, from SimulateBatchWithSensitivities (else empty)
  std::vector<std::array<double, 3>> knot_velocities;  // ξ per knot, if SimOptions::record_velocities
  SimSummary summary;
};

// Frames at which the simulated pose is reset to the measured one (after gaps).
struct PoseResets {
  std::vector<int> frames;  // increasing recording frame indices
};

class SimWorkspace {
 public:
  SimWorkspace() = default;

 private:
  friend class Simulator;
  std::vector<double> xi;        // [knot][3][lane]
  std::vector<double> dxi;       // [knot][3][coefficient][lane]: dξ/dc (sensitivity runs)
  std::vector<double> momentum;  // [3][lane] × 2 previous knots (inertial)
  std::vector<Pose> poses;       // [lane][frame]
};

// Watches a batch frame by frame while it runs, and may stop lanes (early abandoning
// of coefficient sets that can no longer be among the best).
class FrameObserver {
 public:
  virtual ~FrameObserver() = default;
  // Called for the frame offsets 0, 1, … num_frames − 1 in order, as soon as
  // out[w].poses[frame_offset] holds the pose of every lane w in `live` (bit w set).
  // Returns the lanes to go on with, a subset of `live`. A lane left out is no longer
  // solved (its summary is marked stopped); once none is left the batch ends.
  virtual unsigned Frame(int frame_offset, unsigned live) = 0;
};

class Simulator {
 public:
  // Simulates up to kLanes coefficient sets at once; result i goes to out[i].
  // `out` entries are resized on first use and reused afterwards. With an observer,
  // the poses are integrated knot by knot alongside the velocities and reported as
  // they come; the result of a lane the observer never stops is the same, bit for bit.
  // Each trajectory's summary.knots is the number of knots solved before the batch ended.
  static void SimulateBatch(const ShapeDrive& drive, const Coefficients* sets, int count, const SimOptions& opt,
                            const PoseResets* resets, SimWorkspace& ws, Trajectory* out,
                            FrameObserver* observer = nullptr);
  static Trajectory Simulate(const ShapeDrive& drive, const Coefficients& c, const SimOptions& opt,
                             const PoseResets* resets = nullptr);
  // As SimulateBatch without an observer (the same poses, bit for bit), and also
  // fills each result's sensitivities (zero right after a pose reset). Costs about one extra Newton
  // iteration per knot and lane, and a linearised RK4 pass.
  static void SimulateBatchWithSensitivities(const ShapeDrive& drive, const Coefficients* sets, int count,
                                             const SimOptions& opt, const PoseResets* resets, SimWorkspace& ws,
                                             Trajectory* out);
};

// The 14 lab-frame points of every simulated frame, as a kinematics recording
// (frames outside the simulated span are written as missing).
Kinematics TrajectoryToKinematics(const ShapeDrive& drive, const Trajectory& traj, const Kinematics& source);

// Total rigid friction wrench (F_x, F_y, M about p_0) in the head frame at a knot
// for velocity ξ: zero at every quasi-static solution (used by tests and §4 analyses).
std::array<double, 3> FrictionWrench(const KnotGeometry& g, const Coefficients& c, double eps,
                                     const std::array<double, 3>& xi);

}  // namespace wormdrag
