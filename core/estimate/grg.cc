#include "core/estimate/grg.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Dense>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTrialSteps[] = {1.0, 0.3, 0.1, 0.03, 0.01, 0.001};
constexpr int kTrials = static_cast<int>(std::size(kTrialSteps));

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
bool Armijo(const StartState& S, int t, double f_t) {
  double slope = 0;
  for (int i = 0; i < S.d.size(); ++i) slope += S.g[i] * S.d[i];
  return f_t <= S.f + 1e-4 * std::min(kTrialSteps[t], S.alpha_max) * slope;
}

}  // namespace

Status GrgOptions::Validate() const {
  if (max_iterations < 1) return Status::InvalidArgument("GRG max iterations must be >= 1");
  if (!(gradient_tolerance > 0) || !(step_tolerance > 0) || !(fd_step > 0))
    return Status::InvalidArgument("GRG tolerances and finite-difference step must be positive");
  return Status::Ok();
}

std::string GrgResult::OneLineReport() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "f %.6g -> %.6g in %d iterations (%s)", initial_f, f, iterations, termination.c_str());
  return buf;
}

std::string GrgSummary::OneLineReport() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "GRG: %zu starts, best f %.6g, %lld evaluations (%lld with Jacobians) in %d rounds",
                starts.size(), best >= 0 ? starts[best].f : kInf, static_cast<long long>(evaluations),
                static_cast<long long>(jacobians), rounds);
  return buf;
}

namespace {

Result<GrgSummary> Minimize(const std::vector<std::vector<double>>& starts, const std::vector<double>& lower,
                            const BatchObjective& scalar, const ResidualObjective& residual_fn,
                            const ResidualJacobianObjective& jacobian_fn, const GrgOptions& opt) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  const bool least_squares = static_cast<bool>(residual_fn);
  const bool exact = least_squares && static_cast<bool>(jacobian_fn);  // J given: no stencils
  std::vector<std::vector<double>> residuals, jacobians;
  auto sum_squares = [&](std::vector<double>* f) {
    f->resize(residuals.size());
    for (size_t i = 0; i < residuals.size(); ++i) {
      double s = 0;
      for (double r : residuals[i]) s += r * r;
      (*f)[i] = residuals[i].empty() || !std::isfinite(s) ? kInf : s;
    }
  };
  // f of each point of `batch`; for least squares also the residuals (kept for J).
  auto objective = [&](const std::vector<std::vector<double>>& xs, std::vector<double>* f) -> Status {
    if (!least_squares) return scalar(xs, f);
    WORMDRAG_RETURN_IF_ERROR(residual_fn(xs, &residuals));
    if (residuals.size() != xs.size()) return Status::Internal("residual objective returned the wrong count");
    sum_squares(f);
    return Status::Ok();
  };
  if (starts.empty()) return Status::InvalidArgument("GRG needs at least one start");
  const int n = static_cast<int>(lower.size());
  std::vector<StartState> st(starts.size());
  for (size_t s = 0; s < starts.size(); ++s) {
    if (static_cast<int>(starts[s].size()) != n) return Status::InvalidArgument("GRG start has the wrong dimension");
    st[s].x = Eigen::Map<const Eigen::VectorXd>(starts[s].data(), n);
    for (int i = 0; i < n; ++i) st[s].x[i] = std::max(st[s].x[i], lower[i]);
    st[s].Hinv = Eigen::MatrixXd::Identity(n, n);
    st[s].fixed.assign(n, false);
    st[s].step_scale = opt.max_step;
  }
  GrgSummary summary;
  std::vector<std::vector<double>> batch;
  std::vector<double> values;
  auto run = [&]() -> Status {
    values.clear();
    if (batch.empty()) return Status::Ok();
    ++summary.rounds;
    summary.evaluations += static_cast<int64_t>(batch.size());
    return objective(batch, &values);
  };
  // f, residuals and their Jacobians of every point of `batch`.
  auto run_jacobians = [&]() -> Status {
    ++summary.rounds;
    summary.evaluations += static_cast<int64_t>(batch.size());
    summary.jacobians += static_cast<int64_t>(batch.size());
    WORMDRAG_RETURN_IF_ERROR(jacobian_fn(batch, &residuals, &jacobians));
    if (residuals.size() != batch.size() || jacobians.size() != batch.size())
      return Status::Internal("Jacobian objective returned the wrong count");
    sum_squares(&values);
    return Status::Ok();
  };
  const double h = opt.fd_step;

  for (int iter = 0;; ++iter) {
    // Round 1: f and central-difference gradient of every active start that moved
    // (evaluations are deterministic, so a start retrying from the same x keeps them).
    batch.clear();
    std::vector<size_t> owner;
    bool active = false;
    for (size_t s = 0; s < st.size(); ++s) {
      if (st[s].done) continue;
      active = true;
      if (st[s].evaluated) continue;
      const Eigen::VectorXd& x = st[s].x;
      batch.emplace_back(x.data(), x.data() + n);
      owner.push_back(s);
      if (exact) continue;
      for (int i = 0; i < n; ++i) {
        std::vector<double> p(x.data(), x.data() + n), m = p;
        if (opt.forward_differences) {
          p[i] += h;
          batch.push_back(p);
          continue;
        }
        // Central stencil x ± h; within h of the bound, the one-sided x+h, x+2h.
        if (x[i] - h < lower[i]) {
          p[i] += 2 * h;
          m[i] += h;
        } else {
          p[i] += h;
          m[i] -= h;
        }
        batch.push_back(p);
        batch.push_back(m);
      }
    }
    if (!active) break;
    if (!owner.empty()) WORMDRAG_RETURN_IF_ERROR(exact ? run_jacobians() : run());
    size_t k = 0;
    for (size_t s : owner) {
      StartState& S = st[s];
      S.evaluated = true;
      S.f = values[k++];
      if (iter == 0) S.f0 = S.f;
      S.g = Eigen::VectorXd(n);
      const size_t centre = k - 1;
      const int stencil = opt.forward_differences ? 1 : 2;
      if (exact) {
        const std::vector<double>& r0 = residuals[centre];
        const size_t m = r0.size();
        if (std::isfinite(S.f) && jacobians[centre].size() == m * n) {
          const Eigen::Map<const Eigen::MatrixXd> J(jacobians[centre].data(), m, n);
          S.gn = 2 * J.transpose() * J;
          S.g = 2 * J.transpose() * Eigen::Map<const Eigen::VectorXd>(r0.data(), m);
        } else {
          S.g.setConstant(kInf);
        }
      }
      for (int i = 0; i < n && !exact; ++i) {
        if (opt.forward_differences) {
          S.g[i] = (values[k++] - S.f) / h;
          continue;
        }
        const double fp = values[k++], fm = values[k++];
        S.g[i] = S.x[i] - h < lower[i] ? (4 * fm - 3 * S.f - fp) / (2 * h) : (fp - fm) / (2 * h);
      }
      if (least_squares && !exact && std::isfinite(S.f)) {
        // J column i by the same stencil on the residual vectors; g = 2Jᵀr exactly.
        const std::vector<double>& r0 = residuals[centre];
        const size_t m = r0.size();
        Eigen::MatrixXd J(m, n);
        bool ok = true;
        for (int i = 0; i < n; ++i) {
          const auto& rp = residuals[centre + 1 + stencil * i];
          if (opt.forward_differences) {
            if (rp.size() != m) {
              ok = false;
              break;
            }
            for (size_t q = 0; q < m; ++q) J(q, i) = (rp[q] - r0[q]) / h;
            continue;
          }
          const auto& rm = residuals[centre + 2 + 2 * i];
          if (rp.size() != m || rm.size() != m) {
            ok = false;
            break;
          }
          const bool one_sided = S.x[i] - h < lower[i];
          for (size_t q = 0; q < m; ++q)
            J(q, i) = one_sided ? (4 * rm[q] - 3 * r0[q] - rp[q]) / (2 * h) : (rp[q] - rm[q]) / (2 * h);
        }
        if (ok) {
          S.gn = 2 * J.transpose() * J;
          S.g = 2 * J.transpose() * Eigen::Map<const Eigen::VectorXd>(r0.data(), m);
        } else {
          S.gn.resize(0, 0);
        }
      }
      if (!std::isfinite(S.f) || !S.g.allFinite()) {
        S.done = true;
        S.termination = "not finite";
      }
    }

    // Per start: active set, reduced gradient, convergence, direction.
    batch.clear();
    owner.clear();
    for (size_t s = 0; s < st.size(); ++s) {
      StartState& S = st[s];
      if (S.done) continue;
      // BFGS update with the gradient at the new point (over all variables).
      if (S.have_prev && !least_squares) {
        const Eigen::VectorXd sv = S.x - S.x_prev, yv = S.g - S.g_prev;
        const double sy = sv.dot(yv);
        if (sy > 1e-12 * sv.norm() * yv.norm()) {
          const double rho = 1.0 / sy;
          // Shanno–Phua: the first model after a reset has the curvature just seen.
          if (S.identity) S.Hinv = Eigen::MatrixXd::Identity(n, n) * (sy / yv.squaredNorm());
          S.identity = false;
          const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
          S.Hinv = (I - rho * sv * yv.transpose()) * S.Hinv * (I - rho * yv * sv.transpose()) +
                   rho * sv * sv.transpose();
        }
      }
      S.fixed_prev = S.fixed;
      for (int i = 0; i < n; ++i) S.fixed[i] = S.x[i] <= lower[i] + 1e-12 && S.g[i] > 0;
      if (S.fixed != S.fixed_prev) {
        S.Hinv = Eigen::MatrixXd::Identity(n, n);
        S.identity = true;
      }
      Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
      bool stop = false;
      for (int pass = 0; pass <= n; ++pass) {
        // Basic variable: the free one farthest from its bound.
        S.basic = -1;
        if (opt.fix_sum) {
          double best = -1;
          for (int i = 0; i < n; ++i)
            if (!S.fixed[i] && S.x[i] - lower[i] > best) {
              best = S.x[i] - lower[i];
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
        const double fscale = std::max(std::abs(S.f), opt.f_floor);
        bool small = true;
        for (int a2 = 0; a2 < ns; ++a2)
          if (std::abs(r[a2]) * std::max(1.0, std::abs(S.x[sb[a2]])) >= opt.gradient_tolerance * fscale) small = false;
        if (small) {
          S.done = true;
          S.termination = "gradient";
          stop = true;
          break;
        }
        if (S.iterations >= opt.max_iterations) {
          S.done = true;
          S.termination = "max iterations";
          stop = true;
          break;
        }
        // Direction in the reduced space: Gauss–Newton (least squares), BFGS, or
        // steepest descent after a reset.
        Eigen::VectorXd ds;
        if (least_squares && S.gn.size() == n * n) {
          Eigen::MatrixXd Hr = Z.transpose() * S.gn * Z;
          const double top = ns ? Hr.diagonal().maxCoeff() : 0.0;
          for (int a2 = 0; a2 < ns; ++a2) Hr(a2, a2) += S.lambda * Hr(a2, a2) + 1e-14 * top;
          ds = Hr.ldlt().solve(-r);
          S.identity = !ds.allFinite() || ds.dot(r) >= 0;
        } else if (!least_squares && !S.identity) {
          Eigen::MatrixXd Hs(ns, ns);
          for (int a2 = 0; a2 < ns; ++a2)
            for (int b2 = 0; b2 < ns; ++b2) Hs(a2, b2) = S.Hinv(sb[a2], sb[b2]);
          ds = -Hs * r;
          if (ds.dot(r) >= 0) {
            S.Hinv = Eigen::MatrixXd::Identity(n, n);
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
        d = Z * ds;
        // A variable on its bound that the direction would push out becomes nonbasic,
        // and the direction is recomputed without it.
        bool refixed = false;
        for (int i = 0; i < n; ++i)
          if (!S.fixed[i] && S.x[i] <= lower[i] + 1e-12 && d[i] < 0) {
            S.fixed[i] = true;
            refixed = true;
          }
        if (!refixed) break;
      }
      if (stop) continue;
      // Longest feasible step.
      double amax = kInf;
      for (int i = 0; i < n; ++i)
        if (d[i] < 0) amax = std::min(amax, (S.x[i] - lower[i]) / -d[i]);
      S.alpha_max = amax;
      S.d = d;
      owner.push_back(s);
    }
    if (owner.empty()) break;
    // Round 2: the line search, in up to two batches: every start's full step, then the
    // shorter trials of the starts whose full step fails the Armijo test. The pick (the
    // first trial, longest first, that passes Armijo, else the best decrease) is the one
    // that evaluating every trial at once would give.
    std::vector<std::array<double, kTrials>> trial_f(owner.size());
    std::vector<size_t> retry;
    for (int stage = 0; stage < 2; ++stage) {
      batch.clear();
      for (size_t o = 0; o < owner.size(); ++o) {
        if (stage == 1 && !std::binary_search(retry.begin(), retry.end(), o)) continue;
        for (int t = stage; t < (stage == 0 ? 1 : kTrials); ++t) {
          const StartState& S = st[owner[o]];
          Eigen::VectorXd xt = S.x + std::min(kTrialSteps[t], S.alpha_max) * S.d;
          for (int i = 0; i < n; ++i) xt[i] = std::max(xt[i], lower[i]);
          batch.emplace_back(xt.data(), xt.data() + n);
        }
      }
      WORMDRAG_RETURN_IF_ERROR(run());
      size_t k2 = 0;
      for (size_t o = 0; o < owner.size(); ++o) {
        if (stage == 0) {
          trial_f[o][0] = values[k2++];
          if (!Armijo(st[owner[o]], 0, trial_f[o][0])) retry.push_back(o);
        } else if (std::binary_search(retry.begin(), retry.end(), o)) {
          for (int t = 1; t < kTrials; ++t) trial_f[o][t] = values[k2++];
        }
      }
      if (retry.empty()) break;
    }
    for (size_t o = 0; o < owner.size(); ++o) {
      const size_t s = owner[o];
      StartState& S = st[s];
      const bool tried_all = std::binary_search(retry.begin(), retry.end(), o);
      int pick = -1;
      double fpick = S.f;
      for (int t = 0; t < (tried_all ? kTrials : 1) && pick < 0; ++t)
        if (Armijo(S, t, trial_f[o][t])) {
          pick = t;
          fpick = trial_f[o][t];
        }
      if (pick < 0)
        for (int t = 0; t < kTrials; ++t)
          if (trial_f[o][t] < fpick) {
            pick = t;
            fpick = trial_f[o][t];
          }
      ++S.iterations;
      if (least_squares) {
        if (pick == 0)
          S.lambda = std::max(S.lambda / 10, 1e-12);
        else
          S.lambda = std::min(S.lambda * 10, 1e12);
      }
      if (pick < 0 && least_squares && S.lambda < 1e12 && !S.identity) {
        S.lambda = std::min(S.lambda * 100, 1e12);
        continue;
      }
      if (pick < 0) {
        // No decrease along a quasi-Newton direction: retry steepest descent once,
        // otherwise the start has converged as far as f can resolve.
        if (!S.identity) {
          S.Hinv = Eigen::MatrixXd::Identity(n, n);
          S.identity = true;
          S.have_prev = false;
          continue;
        }
        // Even the shortest trial of steepest descent failed: look closer, until the
        // steps are below the tolerance.
        S.step_scale *= 1e-3;
        if (S.step_scale * 1e-3 < opt.step_tolerance) {
          S.done = true;
          S.termination = "line search";
        }
        continue;
      }
      const double alpha = std::min(kTrialSteps[pick], S.alpha_max);
      const Eigen::VectorXd& d = S.d;
      if (S.identity) S.step_scale = std::min(opt.max_step, S.step_scale * (pick == 0 ? 10.0 : 1.0));
      S.x_prev = S.x;
      S.g_prev = S.g;
      S.have_prev = true;
      Eigen::VectorXd xn = S.x + alpha * d;
      for (int i = 0; i < n; ++i) xn[i] = std::max(xn[i], lower[i]);
      if (alpha >= S.alpha_max)  // a bound was reached: snap it exactly
        for (int i = 0; i < n; ++i)
          if (d[i] < 0 && xn[i] - lower[i] < 1e-12 * std::max(1.0, std::abs(S.x[i]))) xn[i] = lower[i];
      const double moved = (xn - S.x).cwiseAbs().maxCoeff();
      S.x = xn;
      S.f = fpick;
      S.evaluated = false;
      if (moved < opt.step_tolerance) {
        S.done = true;
        S.termination = "step";
      }
    }
    // Prune starts far behind the best one.
    if (iter + 1 >= opt.prune_after) {
      double best_f = kInf;
      for (const auto& S : st) best_f = std::min(best_f, S.f);
      for (auto& S : st)
        if (!S.done && S.f > opt.prune_factor * best_f) {
          S.done = true;
          S.termination = "pruned";
        }
    }
    // Merge starts that have met: the worse one stops (its work would repeat).
    for (size_t a = 0; a < st.size(); ++a)
      for (size_t b = 0; b < st.size(); ++b) {
        if (a == b || st[a].done || st[b].f < st[a].f) continue;
        if (st[b].f == st[a].f && b > a) continue;
        if (!st[b].done && (st[a].x - st[b].x).cwiseAbs().maxCoeff() < opt.duplicate_distance) {
          st[b].done = true;
          st[b].termination = "merged";
        }
      }
  }
  for (size_t s = 0; s < st.size(); ++s) {
    GrgResult r;
    r.x.assign(st[s].x.data(), st[s].x.data() + n);
    r.f = st[s].f;
    r.initial_f = st[s].f0;
    r.iterations = st[s].iterations;
    r.termination = st[s].termination;
    summary.starts.push_back(r);
    if (summary.best < 0 || r.f < summary.starts[summary.best].f) summary.best = static_cast<int>(s);
  }
  return summary;
}

}  // namespace

Result<GrgSummary> MinimizeGrg(const std::vector<std::vector<double>>& starts, const std::vector<double>& lower,
                               const BatchObjective& objective, const GrgOptions& opt) {
  return Minimize(starts, lower, objective, nullptr, nullptr, opt);
}

Result<GrgSummary> MinimizeGrgLeastSquares(const std::vector<std::vector<double>>& starts,
                                           const std::vector<double>& lower, const ResidualObjective& residuals,
                                           const GrgOptions& opt, const ResidualJacobianObjective& jacobians) {
  return Minimize(starts, lower, nullptr, residuals, jacobians, opt);
}

}  // namespace wormdrag
