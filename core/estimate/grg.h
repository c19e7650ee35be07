// Generalized reduced gradient (GRG) minimisation with lower bounds and an optional
// linear equality constraint Σ x_i = Σ x0_i (Gabriele & Ragsdell 1976; Lasdon et al.).
//
// At each iterate the variables split into nonbasic ones (held at a bound whose
// gradient pushes outward), one basic variable (solved from the equality, when it is
// on) and superbasic ones, along which the reduced gradient
//     r_S = g_S − g_B ∂x_B/∂x_S     (= g_S − g_B for Σ x = const)
// is followed with a BFGS model of the reduced Hessian; steps stop at bounds, and a
// variable that reaches its bound becomes nonbasic.
//
// Many starts advance in lock step, and each round's function values are requested
// as one batch, so a parallel evaluator is kept busy: the central finite-difference
// stencils of all starts (or their Jacobians, when given), then the full steps of all
// their line searches, then the shorter trials of the starts whose full step failed.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace wormdrag {

struct GrgOptions {
  int max_iterations = 200;          // per start
  double gradient_tolerance = 1e-5;  // stop when every |reduced gradient| · max(1, |x_i|) < tol · max(|f|, f_floor)
  double f_floor = 1e-16;            // absolute scale for f near zero (f in mm² in Phase 3)
  double step_tolerance = 1e-7;      // stop when a step moves every x_i less than this (x units)
  double fd_step = 1e-4;             // central finite-difference step, x units (one-sided at a bound)
  bool forward_differences = false;  // forward x + h only (n + 1 evaluations per gradient, not 2n + 1)
  double max_step = 1.0;             // first (steepest-descent) step moves no variable further than this
  bool fix_sum = false;              // equality constraint Σ x_i = Σ x0_i
  double duplicate_distance = 1e-4;  // a start that comes this close to a better one is merged into it
  // After `prune_after` iterations a start whose f exceeds prune_factor × the best f
  // stops ("pruned"): the best basin is known, and the others' work would be wasted.
  int prune_after = 5;
  double prune_factor = 10;
  Status Validate() const;
};

struct GrgResult {
  std::vector<double> x;
  double f = 0, initial_f = 0;
  int iterations = 0;
  std::string termination;  // "gradient", "step", "line search", "max iterations", "merged"
  std::string OneLineReport() const;
};

struct GrgSummary {
  std::vector<GrgResult> starts;  // in the order given
  int best = -1;                  // index of the best start
  int64_t evaluations = 0;
  int64_t jacobians = 0;  // of the evaluations, those with a Jacobian
  int rounds = 0;         // batches requested
  std::string OneLineReport() const;
};

// f of each point; may fail (then the minimisation stops with that status).
using BatchObjective = std::function<Status(const std::vector<std::vector<double>>& xs, std::vector<double>* f)>;
// The residual vector r of each point, f = ‖r‖² (an empty vector: f = +inf).
using ResidualObjective =
    std::function<Status(const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* r)>;

// The residual vector r of each point and its Jacobian: jacobians[p] column-major,
// n columns ∂r/∂x_i of r.size() values (empty with r: f = +inf).
using ResidualJacobianObjective =
    std::function<Status(const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* r,
                         std::vector<std::vector<double>>* jacobians)>;

// General f: the reduced Hessian is a BFGS model.
Result<GrgSummary> MinimizeGrg(const std::vector<std::vector<double>>& starts, const std::vector<double>& lower,
                               const BatchObjective& objective, const GrgOptions& opt);
// Least squares f = ‖r‖²: the reduced Hessian is the Gauss–Newton model 2 ZᵀJᵀJZ with
// Levenberg–Marquardt damping, J from the same finite-difference stencils, or, when
// `jacobians` is given, from it at the iterate alone (the stencil's 2n extra points
// are not evaluated; line searches still use `residuals`). Converges fast where
// residuals vanish (consistent data) and through narrow valleys.
Result<GrgSummary> MinimizeGrgLeastSquares(const std::vector<std::vector<double>>& starts,
                                           const std::vector<double>& lower, const ResidualObjective& residuals,
                                           const GrgOptions& opt, const ResidualJacobianObjective& jacobians = nullptr);

}  // namespace wormdrag
