// How a GRG start moves (internal/grg_run.h): its model update, active set and
// reduced direction, the batched line search, the step, and pruning and merging.
#include <algorithm>
#include <cmath>

#include "core/estimate/internal/grg_run.h"

namespace wormdrag::grg_internal {

bool Armijo(const StartState& S, int t, double f_t) {
  double slope = 0;
  for (int i = 0; i < S.d.size(); ++i) slope += S.g[i] * S.d[i];
  return f_t <= S.f + 1e-4 * std::min(kTrialSteps[t], S.alpha_max) * slope;
}

// BFGS update with the gradient at the new point (over all variables).
void GrgRun::UpdateBfgs(StartState& S) const {
  const int n = n_;
  const Eigen::VectorXd sv = S.x - S.x_prev, yv = S.g - S.g_prev;
  const double sy = sv.dot(yv);
  if (!(sy > 1e-12 * sv.norm() * yv.norm())) return;
  const double rho = 1.0 / sy;
  // Shanno–Phua: the first model after a reset has the curvature just seen.
  if (S.identity) S.Hinv = Eigen::MatrixXd::Identity(n, n) * (sy / yv.squaredNorm());
  S.identity = false;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  S.Hinv = (I - rho * sv * yv.transpose()) * S.Hinv * (I - rho * yv * sv.transpose()) + rho * sv * sv.transpose();
}

bool GrgRun::ChooseDirection(StartState& S) {
  const int n = n_;
  if (S.have_prev && !least_squares_) UpdateBfgs(S);
  S.fixed_prev = S.fixed;
  for (int i = 0; i < n; ++i) S.fixed[i] = S.x[i] <= lower_[i] + 1e-12 && S.g[i] > 0;
  if (S.fixed != S.fixed_prev) {
    S.Hinv = Eigen::MatrixXd::Identity(n, n);
    S.identity = true;
  }
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  for (int pass = 0; pass <= n; ++pass) {
    // Basic variable: the free one farthest from its bound.
    S.basic = -1;
    if (opt_.fix_sum) {
      double best = -1;
      for (int i = 0; i < n; ++i)
        if (!S.fixed[i] && S.x[i] - lower_[i] > best) {
          best = S.x[i] - lower_[i];
          S.basic = i;
        }
    }
    // Reduced space: superbasic i moves along z_i = e_i − e_B (e_i without the equality).
    std::vector<int> sb;
    for (int i = 0; i < n; ++i)
      if (!S.fixed[i] && i != S.basic) sb.push_back(i);
    const int ns = static_cast<int>(sb.size());
    Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(n, ns);
    for (int a2 = 0; a2 < ns; ++a2) {
      Z(sb[a2], a2) = 1;
      if (S.basic >= 0) Z(S.basic, a2) = -1;
    }
    const Eigen::VectorXd r = Z.transpose() * S.g;  // reduced gradient
    const double fscale = std::max(std::abs(S.f), opt_.f_floor);
    bool small = true;
    for (int a2 = 0; a2 < ns; ++a2)
      if (std::abs(r[a2]) * std::max(1.0, std::abs(S.x[sb[a2]])) >= opt_.gradient_tolerance * fscale) small = false;
    if (small || S.iterations >= opt_.max_iterations) {
      S.done = true;
      S.termination = small ? "gradient" : "max iterations";
      return false;
    }
    d = Z * ReducedDirection(S, sb, Z, r);
    // A variable on its bound that the direction would push out becomes nonbasic,
    // and the direction is recomputed without it.
    bool refixed = false;
    for (int i = 0; i < n; ++i)
      if (!S.fixed[i] && S.x[i] <= lower_[i] + 1e-12 && d[i] < 0) {
        S.fixed[i] = true;
        refixed = true;
      }
    if (!refixed) break;
  }
  // Longest feasible step.
  double amax = kInf;
  for (int i = 0; i < n; ++i)
    if (d[i] < 0) amax = std::min(amax, (S.x[i] - lower_[i]) / -d[i]);
  S.alpha_max = amax;
  S.d = d;
  return true;
}

// Direction in the reduced space: Gauss–Newton (least squares), BFGS, or steepest
// descent after a reset.
Eigen::VectorXd GrgRun::ReducedDirection(StartState& S, const std::vector<int>& sb, const Eigen::MatrixXd& Z,
                                         const Eigen::VectorXd& r) const {
  const int ns = static_cast<int>(sb.size());
  Eigen::VectorXd ds;
  if (least_squares_ && S.gn.size() == n_ * n_) {
    Eigen::MatrixXd Hr = Z.transpose() * S.gn * Z;
    const double top = ns ? Hr.diagonal().maxCoeff() : 0.0;
    for (int a2 = 0; a2 < ns; ++a2) Hr(a2, a2) += S.lambda * Hr(a2, a2) + 1e-14 * top;
    ds = Hr.ldlt().solve(-r);
    S.identity = !ds.allFinite() || ds.dot(r) >= 0;
  } else if (!least_squares_ && !S.identity) {
    Eigen::MatrixXd Hs(ns, ns);
    for (int a2 = 0; a2 < ns; ++a2)
      for (int b2 = 0; b2 < ns; ++b2) Hs(a2, b2) = S.Hinv(sb[a2], sb[b2]);
    ds = -Hs * r;
    if (ds.dot(r) >= 0) {
      S.Hinv = Eigen::MatrixXd::Identity(n_, n_);
      S.identity = true;
    }
  } else {
    S.identity = true;
  }
  if (S.identity) {
    ds = -r;
    const double big = ns ? ds.cwiseAbs().maxCoeff() : 0.0;
    if (big > 0) ds *= S.step_scale / big;
  }
  return ds;
}

// Up to two batches: every start's full step, then the shorter trials of the starts
// whose full step fails the Armijo test (`retry`, ascending indices into `owner`).
Status GrgRun::LineSearch(const std::vector<size_t>& owner, std::vector<std::array<double, kTrials>>* trial_f,
                          std::vector<size_t>* retry) {
  for (int stage = 0; stage < 2; ++stage) {
    batch_.clear();
    for (size_t o = 0; o < owner.size(); ++o) {
      if (stage == 1 && !std::binary_search(retry->begin(), retry->end(), o)) continue;
      for (int t = stage; t < (stage == 0 ? 1 : kTrials); ++t) {
        const StartState& S = st_[owner[o]];
        Eigen::VectorXd xt = S.x + std::min(kTrialSteps[t], S.alpha_max) * S.d;
        for (int i = 0; i < n_; ++i) xt[i] = std::max(xt[i], lower_[i]);
        batch_.emplace_back(xt.data(), xt.data() + n_);
      }
    }
    WORMDRAG_RETURN_IF_ERROR(Evaluate());
    size_t k = 0;
    for (size_t o = 0; o < owner.size(); ++o) {
      if (stage == 0) {
        (*trial_f)[o][0] = values_[k++];
        if (!Armijo(st_[owner[o]], 0, (*trial_f)[o][0])) retry->push_back(o);
      } else if (std::binary_search(retry->begin(), retry->end(), o)) {
        for (int t = 1; t < kTrials; ++t) (*trial_f)[o][t] = values_[k++];
      }
    }
    if (retry->empty()) break;
  }
  return Status::Ok();
}

// The pick is the first trial, longest first, that passes Armijo, else the best
// decrease: what evaluating every trial at once would give.
void GrgRun::TakeStep(StartState& S, const std::array<double, kTrials>& trial_f, bool tried_all) const {
  int pick = -1;
  double fpick = S.f;
  for (int t = 0; t < (tried_all ? kTrials : 1) && pick < 0; ++t)
    if (Armijo(S, t, trial_f[t])) {
      pick = t;
      fpick = trial_f[t];
    }
  if (pick < 0)
    for (int t = 0; t < kTrials; ++t)
      if (trial_f[t] < fpick) {
        pick = t;
        fpick = trial_f[t];
      }
  ++S.iterations;
  if (least_squares_) S.lambda = pick == 0 ? std::max(S.lambda / 10, 1e-12) : std::min(S.lambda * 10, 1e12);
  if (pick < 0 && least_squares_ && S.lambda < 1e12 && !S.identity) {
    S.lambda = std::min(S.lambda * 100, 1e12);
    return;
  }
  if (pick < 0) {
    // No decrease along a quasi-Newton direction: retry steepest descent once,
    // otherwise the start has converged as far as f can resolve.
    if (!S.identity) {
      S.Hinv = Eigen::MatrixXd::Identity(n_, n_);
      S.identity = true;
      S.have_prev = false;
      return;
    }
    // Even the shortest trial of steepest descent failed: look closer, until the
    // steps are below the tolerance.
    S.step_scale *= 1e-3;
    if (S.step_scale * 1e-3 < opt_.step_tolerance) {
      S.done = true;
      S.termination = "line search";
    }
    return;
  }
  const double alpha = std::min(kTrialSteps[pick], S.alpha_max);
  const Eigen::VectorXd& d = S.d;
  if (S.identity) S.step_scale = std::min(opt_.max_step, S.step_scale * (pick == 0 ? 10.0 : 1.0));
  S.x_prev = S.x;
  S.g_prev = S.g;
  S.have_prev = true;
  Eigen::VectorXd xn = S.x + alpha * d;
  for (int i = 0; i < n_; ++i) xn[i] = std::max(xn[i], lower_[i]);
  if (alpha >= S.alpha_max)  // a bound was reached: snap it exactly
    for (int i = 0; i < n_; ++i)
      if (d[i] < 0 && xn[i] - lower_[i] < 1e-12 * std::max(1.0, std::abs(S.x[i]))) xn[i] = lower_[i];
  const double moved = (xn - S.x).cwiseAbs().maxCoeff();
  S.x = xn;
  S.f = fpick;
  S.evaluated = false;
  if (moved < opt_.step_tolerance) {
    S.done = true;
    S.termination = "step";
  }
}

void GrgRun::PruneAndMerge(int iter) {
  // Starts far behind the best one stop: the best basin is known.
  if (iter + 1 >= opt_.prune_after) {
    double best_f = kInf;
    for (const auto& S : st_) best_f = std::min(best_f, S.f);
    for (auto& S : st_)
      if (!S.done && S.f > opt_.prune_factor * best_f) {
        S.done = true;
        S.termination = "pruned";
      }
  }
  // Starts that have met: the worse one stops (its work would repeat).
  for (size_t a = 0; a < st_.size(); ++a)
    for (size_t b = 0; b < st_.size(); ++b) {
      if (a == b || st_[a].done || st_[b].f < st_[a].f) continue;
      if (st_[b].f == st_[a].f && b > a) continue;
      if (!st_[b].done && (st_[a].x - st_[b].x).cwiseAbs().maxCoeff() < opt_.duplicate_distance) {
        st_[b].done = true;
        st_[b].termination = "merged";
      }
    }
}

}  // namespace wormdrag::grg_internal
