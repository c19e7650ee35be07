// Errors in variables: the body shapes refitted together with the friction. The
// noise benchmark's measurement of that route (replicate_bench --shape-refit;
// docs/decisions/0033-shapes-refitted-with-the-friction.md): the estimator does not
// use it.
//
// The smoothed shapes that drive the model lack the detail the smoothing removed
// with the noise, and on a body that barely slips the timing of that detail moves
// the path enough to bias the anisotropy (docs/decisions/0032). Here the shapes are
// unknowns as well: in every shape mode that carries shape (core/filter/shape_modes.h)
// the smoothed series gets a correction, a cubic B-spline in time, and the initial pose
// of each worm an offset. They are fitted with the coefficients to every recorded point
// of every frame (not only the evaluation points), each weighted by the recording's
// tracking noise, plus the smoothing spline's own roughness penalty on the corrected
// modes (λ of GCV, whitened units):
//
//   F = Σ_worms [ Σ_frames,points ‖x_i(t) − r_i(t; shapes, c)‖² / σ̂² + Σ_modes λ_m ‖D³ a_m‖² ]
//
// a penalised maximum likelihood whose shape part, with the path left out, is the
// smoothing itself: the path pulls the shapes only where its evidence outweighs the
// noise. Levenberg–Marquardt, with the shape columns of the Jacobian by forward
// differences of whole simulations and the pose columns exact (a rigid motion of the
// start moves the whole path rigidly).
#pragma once

#include <array>
#include <functional>
#include <string>

#include <Eigen/Core>

#include "core/common/status.h"
#include "core/estimate/paired_path.h"
#include "core/io/kinematics.h"
#include "core/model/friction_law.h"

namespace wormdrag {

struct ShapeModes;

// [frame][mode]: the mode coordinates of every frame of `k`.
Eigen::MatrixXd ModeSeries(const ShapeModes& m, const Kinematics& k);

// `base` with frame i's shape made from row i of `a` (mode coordinates) and its points
// rebuilt on that frame's own best-fit pose and link length.
Kinematics WithModeShapes(const Kinematics& base, const ShapeModes& m, const Eigen::MatrixXd& a);

struct ShapeRefitOptions {
  // Knots per second of the B-splines that carry each shape mode's correction.
  // Default: 20, four per cycle at 5 Hz, where a 1–2 Hz gait still has harmonics;
  // 40 moved the agar-like refit's K_μ by 2.4 % (decision 0033).
  double knots_per_second = 20;
  // Levenberg–Marquardt iterations. Default: 12; on the agar-like tuning pair F is
  // then within 2 % of where 25 iterations end (decision 0033).
  int max_iterations = 12;
  // Stop when an accepted step lowers F (a χ² in noise units) by less than this.
  // Default: 0.01, far below the change of 1 that moves a confidence region.
  double f_tolerance = 0.01;
  // Forward-difference step of a shape column, in noise SDs of the mode. Default: 0.02,
  // linear for the path and far above the solver's tolerance.
  double shape_step = 0.02;
  // Forward-difference step of a coefficient, relative to the largest coefficient.
  // Default: 1e-5.
  double coefficient_step = 1e-5;
  // The roughness penalty's λ of each mode is GCV's times this. Default: 1, the prior
  // the smoothing itself assumes.
  double roughness_scale = 1;
  int threads = 2;  // simulations of the shape columns run in parallel
  // Called after every iteration with its number, F and the coefficients (may be empty).
  std::function<void(int iteration, double f, const Coefficients& c)> progress;
  Status Validate() const;
};

struct ShapeRefitSummary {
  int iterations = 0;
  double initial_f = 0, final_f = 0;  // F in noise units (≈ the number of point coordinates)
  double final_roughness = 0;         // of final_f, the roughness penalty
  // log det of the Gauss–Newton matrix of the nuisance parameters (pose offsets and
  // shape knots) at the end: F + this is −2 log of the likelihood with the shapes
  // integrated out (Laplace), up to a constant, where F alone profiles them.
  double nuisance_logdet = 0;
  int parameters = 0;                // coefficients + pose offsets + shape columns
  std::array<int, 2> shape_modes{};  // per worm, the modes corrected
  std::string termination;
  std::string OneLineReport() const;
};

struct ShapeRefitResult {
  Coefficients set;
  std::array<Kinematics, 2> shapes;  // the refitted recordings (shape, start pose), truncated to t_max
  ShapeRefitSummary summary;
};

// Refits from `start` (the estimate on `smoothed`) and, when `start_shapes` is given,
// from the corrections that come closest to those recordings' shapes (least squares
// in the corrected modes) instead of none. `raw` are the recordings as
// measured, `smoothed` the same after the shape smoothing (same frames), `noise_mm`
// each recording's tracking noise σ̂. Recordings must be gap-free within t_max.
Result<ShapeRefitResult> RefitWithShapes(const std::array<Kinematics, 2>& raw,
                                         const std::array<Kinematics, 2>& smoothed,
                                         const std::array<double, 2>& noise_mm, const Coefficients& start,
                                         const EvaluationOptions& eval, const ShapeRefitOptions& opt,
                                         const std::array<Kinematics, 2>* start_shapes = nullptr);

}  // namespace wormdrag
