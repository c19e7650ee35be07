#include "core/estimate/grg.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/estimate/internal/grg_run.h"

namespace wormdrag {

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
                starts.size(), best >= 0 ? starts[best].f : grg_internal::kInf, static_cast<long long>(evaluations),
                static_cast<long long>(jacobians), rounds);
  return buf;
}

namespace grg_internal {

Status GrgRun::Init(const std::vector<std::vector<double>>& starts) {
  WORMDRAG_RETURN_IF_ERROR(opt_.Validate());
  if (starts.empty()) return Status::InvalidArgument("GRG needs at least one start");
  st_.resize(starts.size());
  for (size_t s = 0; s < starts.size(); ++s) {
    if (static_cast<int>(starts[s].size()) != n_) return Status::InvalidArgument("GRG start has the wrong dimension");
    st_[s].x = Eigen::Map<const Eigen::VectorXd>(starts[s].data(), n_);
    for (int i = 0; i < n_; ++i) st_[s].x[i] = std::max(st_[s].x[i], lower_[i]);
    st_[s].Hinv = Eigen::MatrixXd::Identity(n_, n_);
    st_[s].fixed.assign(n_, false);
    st_[s].step_scale = opt_.max_step;
  }
  return Status::Ok();
}

void GrgRun::SumSquares(std::vector<double>* f) const {
  f->resize(residuals_.size());
  for (size_t i = 0; i < residuals_.size(); ++i) {
    double s = 0;
    for (double r : residuals_[i]) s += r * r;
    (*f)[i] = residuals_[i].empty() || !std::isfinite(s) ? kInf : s;
  }
}

Status GrgRun::Evaluate() {
  values_.clear();
  if (batch_.empty()) return Status::Ok();
  ++summary_.rounds;
  summary_.evaluations += static_cast<int64_t>(batch_.size());
  if (!least_squares_) return scalar_(batch_, &values_);
  WORMDRAG_RETURN_IF_ERROR(residual_fn_(batch_, &residuals_));
  if (residuals_.size() != batch_.size()) return Status::Internal("residual objective returned the wrong count");
  SumSquares(&values_);
  return Status::Ok();
}

Status GrgRun::EvaluateJacobians() {
  ++summary_.rounds;
  summary_.evaluations += static_cast<int64_t>(batch_.size());
  summary_.jacobians += static_cast<int64_t>(batch_.size());
  WORMDRAG_RETURN_IF_ERROR(jacobian_fn_(batch_, &residuals_, &jacobians_));
  if (residuals_.size() != batch_.size() || jacobians_.size() != batch_.size())
    return Status::Internal("Jacobian objective returned the wrong count");
  SumSquares(&values_);
  return Status::Ok();
}

// x, then its finite-difference stencil: x + h e_i (forward), or x ± h e_i (central;
// within h of the bound, the one-sided x + 2h, x + h).
void GrgRun::AppendStencil(const Eigen::VectorXd& x) {
  const double h = opt_.fd_step;
  batch_.emplace_back(x.data(), x.data() + n_);
  if (exact_) return;
  for (int i = 0; i < n_; ++i) {
    std::vector<double> p(x.data(), x.data() + n_), m = p;
    if (opt_.forward_differences) {
      p[i] += h;
      batch_.push_back(p);
      continue;
    }
    if (x[i] - h < lower_[i]) {
      p[i] += 2 * h;
      m[i] += h;
    } else {
      p[i] += h;
      m[i] -= h;
    }
    batch_.push_back(p);
    batch_.push_back(m);
  }
}

Result<bool> GrgRun::GradientRound(int iter) {
  // Evaluations are deterministic, so a start retrying from the same x keeps them.
  batch_.clear();
  std::vector<size_t> owner;
  bool active = false;
  for (size_t s = 0; s < st_.size(); ++s) {
    if (st_[s].done) continue;
    active = true;
    if (st_[s].evaluated) continue;
    AppendStencil(st_[s].x);
    owner.push_back(s);
  }
  if (!active) return false;
  if (!owner.empty()) WORMDRAG_RETURN_IF_ERROR(exact_ ? EvaluateJacobians() : Evaluate());
  size_t k = 0;
  for (size_t s : owner) {
    StartState& S = st_[s];
    S.evaluated = true;
    S.f = values_[k++];
    if (iter == 0) S.f0 = S.f;
    ReadGradient(S, k - 1, &k);
    if (!std::isfinite(S.f) || !S.g.allFinite()) {
      S.done = true;
      S.termination = "not finite";
    }
  }
  return true;
}

// The gradient (and for least squares the Gauss–Newton Hessian) of the start whose
// point is values_[centre], its stencil's values following from *k on.
void GrgRun::ReadGradient(StartState& S, size_t centre, size_t* k) {
  const double h = opt_.fd_step;
  S.g = Eigen::VectorXd(n_);
  if (exact_) {
    const std::vector<double>& r0 = residuals_[centre];
    const size_t m = r0.size();
    if (std::isfinite(S.f) && jacobians_[centre].size() == m * n_) {
      const Eigen::Map<const Eigen::MatrixXd> J(jacobians_[centre].data(), m, n_);
      S.gn = 2 * J.transpose() * J;
      S.g = 2 * J.transpose() * Eigen::Map<const Eigen::VectorXd>(r0.data(), m);
    } else {
      S.g.setConstant(kInf);
    }
    return;
  }
  for (int i = 0; i < n_; ++i) {
    if (opt_.forward_differences) {
      S.g[i] = (values_[(*k)++] - S.f) / h;
      continue;
    }
    const double fp = values_[(*k)++], fm = values_[(*k)++];
    S.g[i] = S.x[i] - h < lower_[i] ? (4 * fm - 3 * S.f - fp) / (2 * h) : (fp - fm) / (2 * h);
  }
  if (least_squares_ && std::isfinite(S.f)) StencilJacobian(S, centre);
}

// J column i by the same stencil on the residual vectors; g = 2Jᵀr exactly.
void GrgRun::StencilJacobian(StartState& S, size_t centre) {
  const double h = opt_.fd_step;
  const int stencil = opt_.forward_differences ? 1 : 2;
  const std::vector<double>& r0 = residuals_[centre];
  const size_t m = r0.size();
  Eigen::MatrixXd J(m, n_);
  for (int i = 0; i < n_; ++i) {
    const auto& rp = residuals_[centre + 1 + stencil * i];
    if (opt_.forward_differences) {
      if (rp.size() != m) {
        S.gn.resize(0, 0);
        return;
      }
      for (size_t q = 0; q < m; ++q) J(q, i) = (rp[q] - r0[q]) / h;
      continue;
    }
    const auto& rm = residuals_[centre + 2 + 2 * i];
    if (rp.size() != m || rm.size() != m) {
      S.gn.resize(0, 0);
      return;
    }
    const bool one_sided = S.x[i] - h < lower_[i];
    for (size_t q = 0; q < m; ++q)
      J(q, i) = one_sided ? (4 * rm[q] - 3 * r0[q] - rp[q]) / (2 * h) : (rp[q] - rm[q]) / (2 * h);
  }
  S.gn = 2 * J.transpose() * J;
  S.g = 2 * J.transpose() * Eigen::Map<const Eigen::VectorXd>(r0.data(), m);
}

Result<GrgSummary> GrgRun::Run() {
  for (int iter = 0;; ++iter) {
    auto active = GradientRound(iter);
    if (!active.ok()) return active.status();
    if (!*active) break;
    std::vector<size_t> owner;
    for (size_t s = 0; s < st_.size(); ++s)
      if (!st_[s].done && ChooseDirection(st_[s])) owner.push_back(s);
    if (owner.empty()) break;
    std::vector<std::array<double, kTrials>> trial_f(owner.size());
    std::vector<size_t> retry;
    WORMDRAG_RETURN_IF_ERROR(LineSearch(owner, &trial_f, &retry));
    for (size_t o = 0; o < owner.size(); ++o)
      TakeStep(st_[owner[o]], trial_f[o], std::binary_search(retry.begin(), retry.end(), o));
    PruneAndMerge(iter);
  }
  for (size_t s = 0; s < st_.size(); ++s) {
    GrgResult r;
    r.x.assign(st_[s].x.data(), st_[s].x.data() + n_);
    r.f = st_[s].f;
    r.initial_f = st_[s].f0;
    r.iterations = st_[s].iterations;
    r.termination = st_[s].termination;
    summary_.starts.push_back(r);
    if (summary_.best < 0 || r.f < summary_.starts[summary_.best].f) summary_.best = static_cast<int>(s);
  }
  return summary_;
}

}  // namespace grg_internal

namespace {

using grg_internal::GrgRun;

Result<GrgSummary> Minimize(const std::vector<std::vector<double>>& starts, const std::vector<double>& lower,
                            const BatchObjective& scalar, const ResidualObjective& residual_fn,
                            const ResidualJacobianObjective& jacobian_fn, const GrgOptions& opt) {
  GrgRun run(lower, scalar, residual_fn, jacobian_fn, opt);
  WORMDRAG_RETURN_IF_ERROR(run.Init(starts));
  return run.Run();
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