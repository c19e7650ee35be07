// Phase 3: local optimisation from the Phase 2 survivors (GRG on the mean squared
// distance, or one of NLopt's methods), and the scale-ray search along the
// coefficients' common factor.
#include "core/estimate/search.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numeric>

#include <nlopt.hpp>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Grid units: x = (μ_n/Δμ, μ_t/Δμ, η_n/Δη, η_t/Δη), so all four are O(1–10).
std::vector<double> ToUnits(const Coefficients& c, const SearchOptions& o) {
  return {c.mu_n / o.d_mu, c.mu_t / o.d_mu, c.eta_n / o.d_eta, c.eta_t / o.d_eta};
}
Coefficients FromUnits(const std::vector<double>& x, const SearchOptions& o) {
  return {x[0] * o.d_mu, x[1] * o.d_mu, x[2] * o.d_eta, x[3] * o.d_eta};
}

// A request of Phase 3: recorded as such, and never served from stored evaluations,
// since its sets are new points off the grid.
EvaluationRequest Phase3Request(Objective objective = Objective::kMeanDistance) {
  EvaluationRequest req;
  req.phase = 3;
  req.reuse = false;
  req.objective = objective;
  return req;
}

std::vector<Coefficients> SetsOf(const std::vector<std::vector<double>>& xs, const SearchOptions& search) {
  std::vector<Coefficients> sets;
  for (const auto& x : xs) sets.push_back(FromUnits(x, search));
  return sets;
}

}  // namespace

const char* Phase3MethodName(Phase3Method m) {
  switch (m) {
    case Phase3Method::kGrg:
      return "grg";
    case Phase3Method::kSlsqp:
      return "slsqp";
    case Phase3Method::kLbfgs:
      return "lbfgs";
    case Phase3Method::kBobyqa:
      return "bobyqa";
    case Phase3Method::kNelderMead:
      return "neldermead";
    case Phase3Method::kNone:
      return "none";
  }
  return "?";
}

Result<Phase3Method> ParsePhase3Method(const std::string& name) {
  for (Phase3Method m : {Phase3Method::kGrg, Phase3Method::kSlsqp, Phase3Method::kLbfgs, Phase3Method::kBobyqa,
                         Phase3Method::kNelderMead, Phase3Method::kNone})
    if (name == Phase3MethodName(m)) return m;
  return Status::InvalidArgument("unknown Phase 3 method '" + name +
                                 "' (expected grg, slsqp, lbfgs, bobyqa, neldermead or none)");
}

Status Phase3Options::Validate() const {
  if (max_evaluations < 1) return Status::InvalidArgument("Phase 3 max evaluations must be >= 1");
  if (!(round_chi2 >= 0)) return Status::InvalidArgument("Phase 3 round_chi2 must be >= 0");
  if (fix_scale && method != Phase3Method::kGrg && method != Phase3Method::kSlsqp && method != Phase3Method::kNone)
    return Status::InvalidArgument(
        std::string("--fix-scale needs a method with equality constraints (grg or slsqp), not ") +
        Phase3MethodName(method));
  return grg.Validate();
}

namespace {

// The mean squared distance of sets, each set stopped once it is proven above its
// cut (EvaluationRequest::set_cuts; kAbandoned then).
using CutObjective = std::function<Status(const std::vector<std::vector<double>>& xs,
                                          const std::vector<RunningCut*>& cuts, std::vector<double>* f)>;

// For each point x, the factor s in [10^−d, 10^d] minimising f(s·x): a log-spaced scan,
// then three zooms (all points of all starts in one batch per round). Inertia alone
// sets the scale, so E is nearly flat along it and descent methods barely move it.
// A zoom's centre is the previous round's best point, whose value is known.
//
// Only each ray's best factor matters, so each ray has a cut (exact early abandoning,
// docs/decisions/0001-early-abandoning.md): its best value so far, the centre's from
// the first zoom on. The batch lists the factors nearest the centre first, every ray's
// alike, so that the cuts are tight before the far factors run. A set above its cut
// can be neither the best nor tie with it, so the factors found are those of a search
// that simulates every set to its end.
Result<std::vector<std::vector<double>>> ScaleRaySearch(const std::vector<std::vector<double>>& points,
                                                        const CutObjective& f, double decades, int64_t* evaluations,
                                                        int* rounds) {
  const int first_half = 12;
  const size_t np = points.size();
  std::vector<double> centre(np, 0.0), step(np, decades / first_half);  // log10 s
  std::vector<double> centre_f(np);
  int half = first_half;
  for (int zoom = 0; zoom < 4; ++zoom) {
    std::vector<std::unique_ptr<RunningCut>> cut(np);
    for (size_t p = 0; p < np; ++p) cut[p] = std::make_unique<RunningCut>(1, zoom > 0 ? centre_f[p] : kInf);
    std::vector<std::vector<double>> batch;
    std::vector<RunningCut*> batch_cuts;
    std::vector<std::pair<size_t, int>> slot;  // (ray, k) of each set of the batch
    for (int d = zoom > 0 ? 1 : 0; d <= half; ++d)
      for (size_t p = 0; p < np; ++p)
        for (int sign : {-1, 1}) {
          if (d == 0 && sign > 0) continue;  // k = 0 once
          const int k = sign * d;
          const double s = std::pow(10.0, centre[p] + k * step[p]);
          std::vector<double> x = points[p];
          for (double& v : x) v *= s;
          batch.push_back(std::move(x));
          batch_cuts.push_back(cut[p].get());
          slot.emplace_back(p, k);
        }
    std::vector<double> v;
    WORMDRAG_RETURN_IF_ERROR(f(batch, batch_cuts, &v));
    *evaluations += static_cast<int64_t>(batch.size());
    ++*rounds;
    const int per = 2 * half + 1;
    std::vector<std::vector<double>> vp(np, std::vector<double>(per, kInf));
    for (size_t i = 0; i < batch.size(); ++i)
      vp[slot[i].first][slot[i].second + half] = IsAbandoned(v[i]) ? kInf : v[i];
    for (size_t p = 0; p < np; ++p) {
      if (zoom > 0) vp[p][half] = centre_f[p];
      int best = half;  // s unchanged wins ties
      for (int k = 0; k < per; ++k)
        if (vp[p][k] < vp[p][best]) best = k;
      centre[p] += (best - half) * step[p];
      centre_f[p] = vp[p][best];
      step[p] /= 4;
    }
    half = 4;
  }
  std::vector<std::vector<double>> out;
  for (size_t p = 0; p < np; ++p) {
    const double s = std::pow(10.0, centre[p]);
    std::vector<double> x = points[p];
    for (double& v : x) v *= s;
    out.push_back(x);
  }
  return out;
}

// NLopt from one start; f and the central-difference gradient come in one batch.
struct NloptContext {
  BatchEvaluator* evaluator;
  const SearchOptions* search;
  double h;
  int64_t evaluations = 0;
  Status status;
};

double NloptObjective(unsigned n, const double* x, double* grad, void* data) {
  auto* ctx = static_cast<NloptContext*>(data);
  if (!ctx->status.ok()) throw nlopt::forced_stop();
  std::vector<std::vector<double>> pts = {std::vector<double>(x, x + n)};
  if (grad)
    for (unsigned i = 0; i < n; ++i) {
      std::vector<double> p(x, x + n), m = p;
      if (x[i] - ctx->h < 0) {
        p[i] += 2 * ctx->h;
        m[i] += ctx->h;
      } else {
        p[i] += ctx->h;
        m[i] -= ctx->h;
      }
      pts.push_back(p);
      pts.push_back(m);
    }
  const std::vector<Coefficients> sets = SetsOf(pts, *ctx->search);
  std::vector<double> e;
  ctx->status = ctx->evaluator->Evaluate(sets, &e, Phase3Request(Objective::kMeanSquaredDistance));
  ctx->evaluations += static_cast<int64_t>(sets.size());
  if (!ctx->status.ok()) throw nlopt::forced_stop();
  if (grad)
    for (unsigned i = 0; i < n; ++i) {
      const double fp = e[1 + 2 * i], fm = e[2 + 2 * i];
      grad[i] = x[i] - ctx->h < 0 ? (4 * fm - 3 * e[0] - fp) / (2 * ctx->h) : (fp - fm) / (2 * ctx->h);
    }
  // NLopt's gradient methods need finite values; an unsimulable set is a wall.
  return std::isfinite(e[0]) ? e[0] : 1e30;
}

struct SumConstraint {
  double target;
};
double SumConstraintFn(unsigned n, const double* x, double* grad, void* data) {
  double s = 0;
  for (unsigned i = 0; i < n; ++i) {
    s += x[i];
    if (grad) grad[i] = 1;
  }
  return s - static_cast<SumConstraint*>(data)->target;
}

// Re-evaluates the Phase 2 winner at full accuracy so the reported E is comparable.
Result<ScoredSet> NoLocalOptimisation(const ScoredSet& start, BatchEvaluator& evaluator, PhaseSummary* summary) {
  std::vector<double> e;
  WORMDRAG_RETURN_IF_ERROR(evaluator.Evaluate({start.set}, &e, Phase3Request()));
  summary->sets = 1;
  summary->termination = "no local optimisation";
  return ScoredSet{start.set, e[0]};
}

// GRG on the mean squared distance, a least-squares problem: smooth, with E's minimiser
// on consistent data (where E itself has a cone that stalls gradient methods), and a
// Gauss–Newton model that crosses the narrow valley in which inertia couples the
// overall scale to v_c.
class GrgProblem {
 public:
  GrgProblem(const SearchOptions& search, const Phase3Options& opt, BatchEvaluator& evaluator)
      : search_(search), opt_(opt), evaluator_(evaluator) {
    if (opt.exact_jacobians && evaluator.HasJacobians())
      jacobians_ = [this](const auto& xs, auto* r, auto* jac) { return Jacobians(xs, r, jac); };
  }
  GrgProblem(const GrgProblem&) = delete;  // jacobians_ calls back into this object
  GrgProblem& operator=(const GrgProblem&) = delete;

  // One GRG from the points; hold keeps their coefficient sum (the scale) fixed.
  Result<GrgSummary> Run(const std::vector<std::vector<double>>& from, bool hold) {
    GrgOptions g = opt_.grg;
    g.fix_sum = hold;
    if (!opt_.fix_scale) g.max_iterations = std::min(g.max_iterations, opt_.round_iterations);
    auto r = MinimizeGrgLeastSquares(
        from, {0, 0, 0, 0}, [this](const auto& xs, auto* res) { return Residuals(xs, res); }, g, jacobians_);
    if (r.ok()) {
      evaluations_ += r->evaluations;
      batches_ += r->rounds;
    }
    return r;
  }

  // The scale-ray search from each end point of a GRG that was neither merged nor pruned.
  Result<std::vector<std::vector<double>>> SearchScale(const GrgSummary& r) {
    std::vector<std::vector<double>> ends;
    for (const auto& s : r.starts)
      if (s.termination != "merged" && s.termination != "pruned") ends.push_back(s.x);
    const CutObjective msd = [this](const auto& xs, const auto& cuts, std::vector<double>* f) {
      EvaluationRequest req = Phase3Request(Objective::kMeanSquaredDistance);
      req.set_cuts = cuts;
      return evaluator_.Evaluate(SetsOf(xs, search_), f, req);
    };
    return ScaleRaySearch(ends, msd, opt_.scale_search_decades, &evaluations_, &batches_);
  }

  // The relative improvement of f a scale round must reach: a change of round_chi2 in
  // the sum of squared residuals.
  double Resolved() const {
    return std::max(1e-6, opt_.round_chi2 / static_cast<double>(std::max<size_t>(residual_count_, 1)));
  }

  bool exact_jacobians() const { return static_cast<bool>(jacobians_); }
  int64_t evaluations() const { return evaluations_; }
  int batches() const { return batches_; }

 private:
  Status Residuals(const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* r) {
    WORMDRAG_RETURN_IF_ERROR(evaluator_.EvaluateResiduals(SetsOf(xs, search_), r, Phase3Request()));
    CountResiduals(*r);
    return Status::Ok();
  }

  // dr/dx_i = dr/dc_i · Δ_i: x is in grid units (ToUnits).
  Status Jacobians(const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* r,
                   std::vector<std::vector<double>>* jac) {
    WORMDRAG_RETURN_IF_ERROR(evaluator_.EvaluateResidualJacobians(SetsOf(xs, search_), r, jac, Phase3Request()));
    CountResiduals(*r);
    const double unit[4] = {search_.d_mu, search_.d_mu, search_.d_eta, search_.d_eta};
    for (auto& J : *jac) {
      const size_t m = J.size() / 4;
      for (int i = 0; i < 4; ++i)
        for (size_t q = 0; q < m; ++q) J[i * m + q] *= unit[i];
    }
    return Status::Ok();
  }

  void CountResiduals(const std::vector<std::vector<double>>& r) {
    for (const auto& ri : r) residual_count_ = std::max(residual_count_, ri.size());
  }

  const SearchOptions& search_;
  const Phase3Options& opt_;
  BatchEvaluator& evaluator_;
  ResidualJacobianObjective jacobians_;
  size_t residual_count_ = 0;  // m: the length of a simulable set's residual vector
  int64_t evaluations_ = 0;
  int batches_ = 0;
};

Result<ScoredSet> GrgPhase(const std::vector<ScoredSet>& starts, const SearchOptions& search, const Phase3Options& opt,
                           BatchEvaluator& evaluator, PhaseSummary* summary) {
  GrgProblem problem(search, opt, evaluator);
  std::vector<std::vector<double>> x0;
  for (const auto& s : starts) x0.push_back(ToUnits(s.set, search));
  // The first GRG holds the scale, which keeps it well conditioned while far from the
  // optimum. Then, unless the user fixes the scale, rounds of (search of the scale ray,
  // free GRG) follow until a round improves the best f by less than the data resolve
  // (Phase3Options::round_chi2): the search moves along the nearly flat scale, the free
  // GRG along the valley that couples it to the ratios.
  auto r = problem.Run(x0, true);
  if (!r.ok()) return r.status();
  int scale_rounds_done = 0;
  for (int round = 0; !opt.fix_scale && round < opt.scale_rounds; ++round) {
    const double before = r->starts[r->best].f;
    auto scaled = problem.SearchScale(*r);
    if (!scaled.ok()) return scaled.status();
    r = problem.Run(*scaled, false);
    if (!r.ok()) return r.status();
    ++scale_rounds_done;
    if (r->starts[r->best].f > (1 - problem.Resolved()) * before) break;
  }
  // The winner is chosen by E, the paper's criterion, among the end points and the
  // starts (at full accuracy): descending on the squared distance can raise E where
  // residuals are uneven (real data), and then the start is the better answer.
  std::vector<Coefficients> ends;
  for (const auto& s : r->starts) ends.push_back(FromUnits(s.x, search));
  for (const auto& s : starts) ends.push_back(s.set);
  std::vector<double> e;
  WORMDRAG_RETURN_IF_ERROR(evaluator.Evaluate(ends, &e, Phase3Request()));
  const size_t bi = static_cast<size_t>(std::min_element(e.begin(), e.end()) - e.begin());
  summary->sets = problem.evaluations() + static_cast<int64_t>(ends.size());
  char buf[160];
  std::snprintf(buf, sizeof buf, "GRG (Gauss-Newton, %s Jacobians), %d scale rounds, %d batches; winning start ",
                problem.exact_jacobians() ? "exact" : "finite-difference", scale_rounds_done, problem.batches());
  summary->termination = bi < r->starts.size() ? buf + r->starts[bi].OneLineReport()
                                               : std::string(buf) + "none better than a start";
  return ScoredSet{ends[bi], e[bi]};
}

Result<ScoredSet> NloptPhase(const std::vector<ScoredSet>& starts, const SearchOptions& search,
                             const Phase3Options& opt, BatchEvaluator& evaluator, PhaseSummary* summary) {
  const nlopt::algorithm alg = opt.method == Phase3Method::kSlsqp    ? nlopt::LD_SLSQP
                               : opt.method == Phase3Method::kLbfgs  ? nlopt::LD_LBFGS
                               : opt.method == Phase3Method::kBobyqa ? nlopt::LN_BOBYQA
                                                                     : nlopt::LN_NELDERMEAD;
  NloptContext ctx{&evaluator, &search, opt.grg.fd_step, 0, Status::Ok()};
  ScoredSet best{starts.front().set, kInf};
  std::string why;
  for (const auto& s : starts) {
    try {
      nlopt::opt o(alg, 4);
      o.set_lower_bounds(std::vector<double>(4, 0.0));
      o.set_min_objective(NloptObjective, &ctx);
      o.set_xtol_abs(opt.grg.step_tolerance);
      o.set_ftol_rel(1e-10);
      o.set_maxeval(opt.max_evaluations);
      std::vector<double> x = ToUnits(s.set, search);
      SumConstraint sc{std::accumulate(x.begin(), x.end(), 0.0)};
      if (opt.fix_scale) o.add_equality_constraint(SumConstraintFn, &sc, 1e-10);
      if (alg == nlopt::LN_BOBYQA || alg == nlopt::LN_NELDERMEAD) o.set_initial_step(std::vector<double>(4, 0.25));
      double f = 0;
      const nlopt::result res = o.optimize(x, f);
      std::vector<double> e;
      WORMDRAG_RETURN_IF_ERROR(evaluator.Evaluate({FromUnits(x, search)}, &e, Phase3Request()));
      if (e[0] < best.e) {
        best = {FromUnits(x, search), e[0]};
        why = "nlopt result " + std::to_string(static_cast<int>(res));
      }
    } catch (const nlopt::forced_stop&) { return ctx.status; } catch (const std::exception& e) {
      // A start NLopt cannot handle (e.g. roundoff-limited) is skipped, not fatal.
      why = std::string("nlopt: ") + e.what();
    }
  }
  summary->sets = ctx.evaluations;
  summary->termination = why;
  return best;
}

}  // namespace

Result<ScoredSet> RunPhase3(const std::vector<ScoredSet>& starts, const SearchOptions& search, const Phase3Options& opt,
                            BatchEvaluator& evaluator, PhaseSummary* summary) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  const auto t0 = std::chrono::steady_clock::now();
  summary->name = std::string("phase3 (") + Phase3MethodName(opt.method) + ")";
  if (starts.empty()) return Status::FailedPrecondition("Phase 3 has no start: every refined set failed to simulate");
  auto best = opt.method == Phase3Method::kNone  ? NoLocalOptimisation(starts.front(), evaluator, summary)
              : opt.method == Phase3Method::kGrg ? GrgPhase(starts, search, opt, evaluator, summary)
                                                 : NloptPhase(starts, search, opt, evaluator, summary);
  if (!best.ok()) return best.status();
  summary->best = *best;
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return best;
}

}  // namespace wormdrag
