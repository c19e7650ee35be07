// Fitting: the least-squares fit of a model (coefficients and, optionally, one effect's
// parameters) to prepared data by the GRG, the held-out scoring of a model, the starts,
// and the base fit stage.
#include <algorithm>
#include <cmath>

#include "core/common/parallel.h"
#include "core/diagnose/internal/stages.h"
#include "core/estimate/estimator.h"
#include "core/estimate/grg.h"

namespace wormdrag::diagnose {
namespace {

using internal::kDEta;
using internal::kDMu;
using internal::kInf;
using internal::Run;
using internal::ToUnits;
using internal::UnitsAtSum;

inline Vec2 SimPoint(const Pose& g, const Vec2& m) {
  const double c = std::cos(g.q0), s = std::sin(g.q0);
  return {g.x + c * m.x() - s * m.y(), g.y + s * m.x() + c * m.y()};
}

// The least-squares problem of one FitSpec. Variables: the 4 coefficients in grid units,
// rescaled to the start's sum S0 (the overall scale is unobservable), then the effect's
// parameters in their own grid units (EffectInfo::unit) from their lower bound; worm w's
// are variables 4 + w·ne … (w = 0 unless per_worm).
class FitProblem {
 public:
  FitProblem(const EffectData& data, const FitSpec& spec)
      : data_(data), spec_(spec), info_(spec.has_effect ? &InfoOf(spec.effect) : nullptr) {
    ne_ = info_ ? static_cast<int>(info_->params.size()) : 0;
    np_ = spec.per_worm && info_ ? 2 * ne_ : ne_;
    const auto u0 = ToUnits(spec.start);
    s0_ = u0[0] + u0[1] + u0[2] + u0[3];
    for (const auto& w : data.worms)
      for (const auto& f : w.frames)
        if (spec.train_parity < 0 || f.block % 2 == spec.train_parity) count_ += static_cast<int>(f.model.size());
    scale_ = count_ > 0 ? 1.0 / std::sqrt(static_cast<double>(count_)) : 0.0;
    prior_units_ = UnitsAtSum(spec.prior, s0_);
  }

  Status Check() const {
    if (!(s0_ > 0)) return Status::InvalidArgument("the start coefficients are all zero");
    if (count_ == 0) return Status::InvalidArgument("no training frames");
    return Status::Ok();
  }
  int variables() const { return 4 + np_; }

  void Decode(const std::vector<double>& x, Coefficients* c, std::array<EffectParams, 2>* p) const {
    const double s = x[0] + x[1] + x[2] + x[3];
    const double k = s > 0 ? s0_ / s : 0;
    *c = {x[0] * k * kDMu, x[1] * k * kDMu, x[2] * k * kDEta, x[3] * k * kDEta};
    for (int w = 0; w < 2; ++w) {
      (*p)[w] = EffectParams{};
      if (!info_) continue;
      const int o = 4 + (np_ > ne_ ? w * ne_ : 0);
      std::vector<double> v(ne_);
      for (int i = 0; i < ne_; ++i) v[i] = std::min(info_->upper[i], info_->lower[i] + x[o + i] * info_->unit[i]);
      SetParams(&(*p)[w], spec_.effect, v);
    }
  }

  // The residuals at x into *r: the scaled point distances of the training frames, the
  // ridge, the upper-bound penalties. Left empty where x cannot be simulated.
  void Residuals(const std::vector<double>& x, std::vector<double>* r) const {
    Coefficients c;
    std::array<EffectParams, 2> p;
    Decode(x, &c, &p);
    if (!QuasiStaticSingularity(c).empty()) return;
    r->reserve(2 * count_);
    for (int wi = 0; wi < 2; ++wi) {
      const EffectRecording& w = data_.worms[wi];
      const EffectTrajectory t = Run(w, c, p[wi], spec_.blocked, spec_.epsilon);
      if (!t.ok()) {
        r->clear();
        return;
      }
      for (const auto& f : w.frames) {
        if (spec_.train_parity >= 0 && f.block % 2 != spec_.train_parity) continue;
        const Pose& g = t.poses[f.frame - t.first_frame];
        for (size_t k = 0; k < f.model.size(); ++k) {
          const Vec2 d = SimPoint(g, f.model[k]) - f.measured[k];
          r->push_back(scale_ * d.x());
          r->push_back(scale_ * d.y());
        }
      }
    }
    if (spec_.prior_weight > 0) {
      const auto u = ToUnits(c);
      const double delta = 0.02 * s0_;
      for (int k = 0; k < 4; ++k)
        r->push_back(spec_.prior_weight * std::log((u[k] + delta) / (prior_units_[k] + delta)));
    }
    // Upper bounds (GRG knows only lower ones): beyond one, the parameter is held at it
    // and a penalty residual pulls the variable back, so the fit never stalls on a flat
    // plateau.
    if (info_)
      for (int v = 0; v < np_; ++v) {
        const int k = v % ne_;
        const double over = x[4 + v] - (info_->upper[k] - info_->lower[k]) / info_->unit[k];
        r->push_back(over > 0 ? 0.05 * over : 0.0);
      }
  }

  // Every coefficient start with every effect start. A per-worm fit's effect start gives
  // both worms' values, or one set for both.
  std::vector<std::vector<double>> Starts() const {
    std::vector<std::vector<double>> effect_starts = spec_.effect_starts;
    if (info_ && effect_starts.empty()) effect_starts.push_back(info_->neutral);
    if (!info_) effect_starts = {{}};
    std::vector<Coefficients> coef_starts = {spec_.start};
    coef_starts.insert(coef_starts.end(), spec_.extra_starts.begin(), spec_.extra_starts.end());
    std::vector<std::vector<double>> starts;
    for (const auto& cs : coef_starts) {
      const auto u = UnitsAtSum(cs, s0_);
      for (const auto& es : effect_starts) {
        std::vector<double> x(4);
        for (int i = 0; i < 4; ++i) x[i] = std::max(u[i], 1e-3);
        for (int v = 0; v < np_; ++v) {
          const int k = v % ne_;
          x.push_back((es[static_cast<int>(es.size()) == np_ ? v : k] - info_->lower[k]) / info_->unit[k]);
        }
        starts.push_back(x);
      }
    }
    return starts;
  }

  FitOutcome Outcome(const std::vector<double>& x, double f, long evaluations) const {
    FitOutcome out;
    std::array<EffectParams, 2> p;
    Decode(x, &out.coef, &p);
    out.effects = p[0];
    if (info_) {
      out.params = GetParams(p[0], spec_.effect);
      if (np_ > ne_) {
        out.second_worm_effects = p[1];
        for (double v : GetParams(p[1], spec_.effect)) out.params.push_back(v);
      }
    }
    out.train_mse = f;
    out.evaluations = evaluations;
    return out;
  }

 private:
  const EffectData& data_;
  const FitSpec& spec_;
  const EffectInfo* info_;
  int ne_ = 0, np_ = 0;  // the effect's parameters; the effect variables (2 × ne_ per worm)
  double s0_ = 0;        // the start's coefficient sum in grid units
  int count_ = 0;        // training points
  double scale_ = 0;     // 1 / √count_: the residuals' sum of squares is the training MSE
  std::array<double, 4> prior_units_{};
};

GrgOptions FitGrgOptions(const FitSpec& spec) {
  GrgOptions g;
  g.max_iterations = spec.iterations;
  // Forward differences need the smaller step (their error is O(h); at 1e-3 units it
  // biases time_drift's recovery by 0.2, at 1e-4 every clean recovery test passes).
  g.fd_step = spec.forward_differences ? 1e-4 : 1e-3;
  g.forward_differences = spec.forward_differences;
  g.step_tolerance = 1e-5;
  g.gradient_tolerance = 1e-6;
  g.f_floor = 1e-14;
  g.prune_after = 4;
  g.prune_factor = 3;
  return g;
}

}  // namespace

namespace internal {

EffectTrajectory Run(const EffectRecording& w, const Coefficients& c, const EffectParams& p, bool blocked, double eps) {
  EffectSimOptions o;
  o.epsilon = eps;
  if (blocked) o.reset_frames = w.block_starts;
  return SimulateEffects(*w.drive, c, p, o);
}

std::vector<Coefficients> FurtherStarts(const Coefficients& around, const DiagnoseOptions& o) {
  if (!o.base_multistart) return {};
  auto starts = BaseStarts(around);
  if (!o.base_grid) starts.push_back(o.start);
  return starts;
}

}  // namespace internal

BlockScores ScoreBlocks(const EffectData& data, const Coefficients& c, const EffectParams& p, bool blocked,
                        double eps) {
  BlockScores s;
  const int B = data.blocks;
  s.sum.assign(2 * B, 0);
  s.sum_sq.assign(2 * B, 0);
  s.count.assign(2 * B, 0);
  for (int j = 0; j < 2; ++j) {
    const auto& w = data.worms[j];
    const EffectTrajectory t = Run(w, c, p, blocked, eps);
    for (const auto& f : w.frames) {
      const int idx = j * B + f.block;
      for (size_t k = 0; k < f.model.size(); ++k) {
        double d2 = kInf;
        if (t.ok()) {
          const Vec2 r = SimPoint(t.poses[f.frame - t.first_frame], f.model[k]) - f.measured[k];
          d2 = r.squaredNorm();
        }
        s.sum[idx] += std::sqrt(d2);
        s.sum_sq[idx] += d2;
        s.count[idx] += 1;
      }
    }
  }
  return s;
}

Result<FitOutcome> FitModel(const EffectData& data, const FitSpec& spec) {
  const FitProblem problem(data, spec);
  WORMDRAG_RETURN_IF_ERROR(problem.Check());
  long evaluations = 0;
  // The best point evaluated so far (GRG's end point is used unless worse). It is
  // picked after each batch in the batch's order, so that of equal points the first
  // wins whichever thread finished first.
  double best_f = kInf;
  std::vector<double> best_x;
  ResidualObjective residuals = [&](const std::vector<std::vector<double>>& xs,
                                    std::vector<std::vector<double>>* out) -> Status {
    out->assign(xs.size(), {});
    evaluations += static_cast<long>(xs.size());
    std::vector<double> fs(xs.size(), kInf);
    ParallelFor(static_cast<int64_t>(xs.size()), spec.threads, [&](int, int64_t i) {
      std::vector<double>& r = (*out)[i];
      problem.Residuals(xs[i], &r);
      if (r.empty()) return;
      double f = 0;
      for (double v : r) f += v * v;
      fs[i] = f;
    });
    for (size_t i = 0; i < xs.size(); ++i) {
      if (fs[i] < best_f) {
        best_f = fs[i];
        best_x = xs[i];
      }
    }
    return Status::Ok();
  };
  // Coefficients stay above 1e-3 grid units: a set without tangential or normal
  // friction has no quasi-static solution.
  std::vector<double> lower(problem.variables(), 0.0);
  for (int i = 0; i < 4; ++i) lower[i] = 1e-3;
  auto r = MinimizeGrgLeastSquares(problem.Starts(), lower, residuals, FitGrgOptions(spec));
  if (!r.ok()) return r.status();
  const GrgResult& best = r->starts[r->best];
  std::vector<double> x = best.x;
  double f = best.f;
  if (!(f <= best_f) && !best_x.empty()) {
    x = best_x;
    f = best_f;
  }
  if (!std::isfinite(f)) return Status::FailedPrecondition("the fit found no set that could be simulated");
  return problem.Outcome(x, f, evaluations);
}

std::vector<Coefficients> BaseStarts(const Coefficients& c) {
  // Both normal/tangential ratios ×⅖ and ×2.5, and the Coulomb pair ×⅓ or ×3 against
  // the viscous one: the corners of a box around `c` in the three observable directions.
  std::vector<Coefficients> out;
  for (double rn : {0.4, 2.5})
    for (double balance : {1.0 / 3, 3.0})
      for (double re : {0.4, 2.5}) out.push_back({c.mu_n * rn * balance, c.mu_t * balance, c.eta_n * re, c.eta_t});
  return out;
}

bool StayedAtStart(Effect e, const std::vector<double>& params, const std::vector<std::vector<double>>& starts) {
  const EffectInfo& info = InfoOf(e);
  const size_t ne = info.params.size();
  if (ne == 0 || params.empty() || params.size() % ne != 0) return false;
  for (size_t w = 0; w < params.size(); w += ne) {
    bool at_a_start = false;
    for (const auto& s : starts) {
      if (s.size() != ne && s.size() != params.size()) continue;
      bool here = true;
      for (size_t k = 0; k < ne && here; ++k)
        here = std::abs(params[w + k] - s[s.size() == ne ? k : w + k]) < kUnmovedUnits * info.unit[k];
      at_a_start = at_a_start || here;
    }
    if (!at_a_start) return false;
  }
  return true;
}

std::vector<std::vector<double>> EffectStarts(Effect e) {
  switch (e) {
    case Effect::kPowerLaw:
      return {{1.0}, {0.5}};
    case Effect::kStiction:
      return {{0.0}, {2.0}};
    case Effect::kLateralAsymmetry:
      return {{0.0}, {0.6}};
    case Effect::kLag:
      return {{0.0}, {0.08}};
    default:
      return {InfoOf(e).neutral};
  }
}

namespace internal {

Status FitBase(DiagnosisRun* run) {
  const DiagnoseOptions& o = run->o;
  Diagnosis& out = run->out;
  // The paper's three phases (quasi-static), or GRG from the given start.
  run->Progress("base fit", 0);
  if (o.base_grid) {
    EvaluationOptions ev;
    ev.points = o.points;
    ev.t_max = 1e9;
    for (const auto& k : run->prepared) ev.t_max = std::min(ev.t_max, k.Duration());
    ev.sim.solver = Solver::kQuasiStatic;
    ev.sim.epsilon = o.epsilon;
    ev.substeps = o.substeps;
    EstimateOptions eo;
    eo.eval = ev;
    eo.screening_substeps = 1;
    eo.threads = run->threads;
    eo.phase3.scale_rounds = 0;
    eo.phase3.fix_scale = true;
    auto pair = PairedPath::Create(run->prepared, out.names, ev);
    if (!pair.ok()) return pair.status();
    auto screening_pair = PairedPath::Create(run->prepared, out.names, eo.ScreeningEval());
    if (!screening_pair.ok()) return screening_pair.status();
    LocalEvaluator screening(*screening_pair, run->threads), accurate(*pair, run->threads);
    EstimateHooks hooks;
    hooks.progress = [&](const std::string& phase, int64_t done, int64_t total, double) {
      run->Progress("base fit " + phase, total ? double(done) / total : 0);
    };
    hooks.cancelled = o.cancelled;
    auto est = RunEstimate(screening, accurate, eo, (*pair)->mean_body_length(), hooks);
    if (!est.ok()) return est.status().Annotate("base fit");
    out.base = est->best.set;
  } else {
    FitTask t;
    t.spec.start = o.start;
    if (o.base_multistart) t.spec.extra_starts = BaseStarts(o.start);
    t.spec.blocked = false;
    t.spec.iterations = o.base_iterations;
    t.spec.epsilon = o.epsilon;
    auto fit = run->RunFits({t});
    if (!fit.ok()) return fit.status().Annotate("base fit");
    out.base = (*fit)[0].coef;
  }
  {
    const BlockScores s = ScoreBlocks(run->data, out.base, {}, false, o.epsilon);
    out.base_e_mm = std::accumulate(s.sum.begin(), s.sum.end(), 0.0) /
                    std::accumulate(s.count.begin(), s.count.end(), 0.0);
  }
  // The CV scores blocked paths: its fits start from (and its ridge holds them near) the
  // base refitted on that objective with all blocks; the null replicates are made from
  // it too, so that they mimic the data as the CV sees it.
  run->Progress("base refit (blocked)", 0);
  FitTask t;
  t.spec.start = out.base;
  t.spec.extra_starts = FurtherStarts(out.base, o);
  t.spec.blocked = true;
  t.spec.iterations = o.base_iterations;
  t.spec.epsilon = o.epsilon;
  auto fit = run->RunFits({t});
  if (!fit.ok()) return fit.status().Annotate("blocked base refit");
  run->cv_base = (*fit)[0].coef;
  out.cv_base = run->cv_base;
  run->ridge_mm = o.cv_ridge * std::sqrt(2.0) * out.noise_sigma;
  return Status::Ok();
}

}  // namespace internal
}  // namespace wormdrag::diagnose
