// The GRG minimiser's machinery (grg.h): the state of one start and one run of many
// starts in lock step. Private to core/estimate: grg.cc evaluates (the gradient round,
// the stencils), grg_step.cc moves (direction, line search, step, pruning).
#pragma once

#include <array>
#include <cstddef>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "core/estimate/grg.h"

namespace wormdrag::grg_internal {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
// The line search's trial steps, longest first, in units of the direction (each capped
// at the longest feasible step).
inline constexpr double kTrialSteps[] = {1.0, 0.3, 0.1, 0.03, 0.01, 0.001};
inline constexpr int kTrials = static_cast<int>(std::size(kTrialSteps));

// One start of a run: its iterate, gradient and model, and where its search stands.
struct StartState {
  Eigen::VectorXd x, g, x_prev, g_prev, d;
  double f = kInf, f0 = kInf;
  Eigen::MatrixXd Hinv;     // BFGS inverse Hessian over all variables (used on S)
  std::vector<bool> fixed;  // nonbasic at bound
  std::vector<bool> fixed_prev;
  int basic = -1;
  int iterations = 0;
  bool done = false, have_prev = false;
  bool evaluated = false;  // f, g (and gn) are those of x: a retry from x needs no new evaluation
  bool identity = true;    // Hinv was just reset: scale the step and the first update
  std::string termination;
  double alpha_max = 0;
  double step_scale = 0;  // length of a steepest-descent step (x units), adapted
  Eigen::MatrixXd gn;     // Gauss–Newton Hessian 2JᵀJ (least squares only)
  double lambda = 1e-3;   // Levenberg–Marquardt damping (relative to the diagonal)
};

// Armijo's sufficient decrease for trial t (f_t its value) along S.d.
bool Armijo(const StartState& S, int t, double f_t);

// One minimisation: the starts' states and the batches of evaluations they share.
class GrgRun {
 public:
  GrgRun(const std::vector<double>& lower, const BatchObjective& scalar, const ResidualObjective& residual_fn,
         const ResidualJacobianObjective& jacobian_fn, const GrgOptions& opt)
      : lower_(lower),
        n_(static_cast<int>(lower.size())),
        scalar_(scalar),
        residual_fn_(residual_fn),
        jacobian_fn_(jacobian_fn),
        opt_(opt),
        least_squares_(static_cast<bool>(residual_fn)),
        exact_(least_squares_ && static_cast<bool>(jacobian_fn)) {}

  Status Init(const std::vector<std::vector<double>>& starts);
  Result<GrgSummary> Run();

 private:
  void SumSquares(std::vector<double>* f) const;
  Status Evaluate();           // f of every point of batch_ (and residuals_)
  Status EvaluateJacobians();  // f, residuals_ and jacobians_ of every point of batch_
  // Round 1: f and gradient of every active start that moved; false when none is active.
  Result<bool> GradientRound(int iter);
  void AppendStencil(const Eigen::VectorXd& x);
  void ReadGradient(StartState& S, size_t centre, size_t* k);
  void StencilJacobian(StartState& S, size_t centre);
  // Per start: model update, active set, reduced direction; false when the start stops.
  bool ChooseDirection(StartState& S);
  void UpdateBfgs(StartState& S) const;
  Eigen::VectorXd ReducedDirection(StartState& S, const std::vector<int>& sb, const Eigen::MatrixXd& Z,
                                   const Eigen::VectorXd& r) const;
  // Round 2: the trials of the line searches of the starts in `owner`.
  Status LineSearch(const std::vector<size_t>& owner, std::vector<std::array<double, kTrials>>* trial_f,
                    std::vector<size_t>* retry);
  void TakeStep(StartState& S, const std::array<double, kTrials>& trial_f, bool tried_all) const;
  void PruneAndMerge(int iter);

  const std::vector<double>& lower_;
  const int n_;
  const BatchObjective& scalar_;
  const ResidualObjective& residual_fn_;
  const ResidualJacobianObjective& jacobian_fn_;
  const GrgOptions& opt_;
  const bool least_squares_;
  const bool exact_;  // J given: no stencils
  std::vector<StartState> st_;
  GrgSummary summary_;
  std::vector<std::vector<double>> batch_, residuals_, jacobians_;
  std::vector<double> values_;
};

}  // namespace wormdrag::grg_internal
