// The effect-aware quasi-static simulator (scalar). Same model and numerics as
// core/sim's quasi-static solver when every effect is neutral (tested to 1e-9 BL, the
// knot solvers' difference):
// per knot the head-frame rigid velocity ξ solves the friction balance
//     R(ξ) = Σ_i J_i f_i(J_i ξ + b_i) − F_ext = 0,
// here with a damped Newton method on R (merit ‖R‖², backtracking), warm-started from
// the linear extrapolation of the previous knots. For the convex laws R is the gradient
// of the dissipation potential and the root is its unique minimiser; Stribeck stiction
// makes f non-monotone (several roots may exist), and ξ is then the root of least
// potential among Newton's from the warm start and from the roots of the two convex laws
// that bracket it (docs/conventions.md §2: ξ minimises Φ), so that it depends on the shape alone,
// not on which root the previous knot held. The pose is integrated with core/sim's own
// pose step (core/sim/pose_step.h: RK4 with cubic midpoints, the flow added to the
// lab-frame rate), so the same knot velocities give core/sim's poses bit for bit; with
// the out-of-catalogue `tether` force and `boundary` friction, which depend on the pose, by
// Heun's method with a re-solve at the predicted pose.
//
// Only the quasi-static solver is offered: the diagnosis is scale-free (docs/conventions.md §2: the
// inertial signal is ~1e-6 BL) and every effect in the catalogue keeps that invariance.
#pragma once

#include <array>
#include <functional>
#include <utility>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/effects.h"
#include "core/io/kinematics.h"
#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"

namespace wormdrag::diagnose {

// A ShapeDrive plus what effects need: the joint angles at any time (lag, stretch),
// the analysed span (time_drift) and the runs of missing frames (gap_offset).
class EffectDrive {
 public:
  // Joint-angle splines through the valid frames, built exactly as ShapeDrive::Build.
  static Result<EffectDrive> FromKinematics(const Kinematics& k, const BodyModel& body, int substeps);
  // An analytic shape; `gaps` lists runs [first, last] of frames to treat as missing
  // (for gap_offset), each with a frame on both sides.
  static Result<EffectDrive> FromFunction(const std::vector<double>& frame_times,
                                          const ShapeDrive::ShapeFunction& shape, const BodyModel& body,
                                          const Pose& initial, int substeps,
                                          std::vector<std::pair<int, int>> gaps = {});
  const ShapeDrive& drive() const { return drive_; }
  // q and q̇ at time t, clamped to the drive's span.
  void ShapeAt(double t, Shape* q, Shape* qdot) const;
  double t0() const { return drive_.knots().front().t; }
  double span() const { return drive_.knots().back().t - drive_.knots().front().t; }
  const std::vector<std::pair<int, int>>& gaps() const { return gaps_; }

 private:
  ShapeDrive drive_;
  ShapeDrive::ShapeFunction shape_;
  std::vector<std::pair<int, int>> gaps_;
};

struct EffectSimOptions {
  double epsilon = kDefaultEpsilon;  // smooth-sign width, mm/s
  double velocity_tolerance = 1e-8;  // Newton stops when the step in V (and ω·L) is below this, mm/s
  int max_iterations = 100;          // per knot
  std::vector<int> reset_frames;     // recording frames where the pose restarts from the measured one
  Status Validate() const;
};

struct EffectTrajectory {
  int first_frame = 0;
  std::vector<Pose> poses;                             // per frame first_frame … last frame
  std::vector<double> link_length;                     // per frame (differs from the body's only with `stretch`)
  std::vector<std::array<double, 3>> knot_velocities;  // ξ per knot (relative to the medium)
  long knots = 0, iterations = 0, unconverged = 0;
  bool ok() const { return unconverged == 0 && !poses.empty(); }
};

EffectTrajectory SimulateEffects(const EffectDrive& d, const Coefficients& c, const EffectParams& p,
                                 const EffectSimOptions& opt);

// The friction (+ tether) wrench in the head frame at knot geometry g, time fraction
// tau = (t − t0)/T, velocity ξ (relative to the medium): zero at every solution.
// boundary, which needs the pose, acts only in SimulateEffects.
std::array<double, 3> EffectWrench(const KnotGeometry& g, const Coefficients& c, const EffectParams& p, double tau,
                                   double eps, const std::array<double, 3>& xi);

// Solves one knot (exposed for tests): ξ in/out (warm start / solution). Returns false
// if the tolerance was not met.
bool SolveEffectKnot(const KnotGeometry& g, const Coefficients& c, const EffectParams& p, double tau, double eps,
                     const std::array<double, 3>& external, double L, double tol, int max_iterations,
                     std::array<double, 3>* xi, long* iterations);

// Lab-frame points of frame f of a simulated trajectory.
Points EffectPoints(const EffectDrive& d, const EffectTrajectory& t, int frame);

}  // namespace wormdrag::diagnose
