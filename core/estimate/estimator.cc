#include "core/estimate/estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Json SetJson(const ScoredSet& s) {
  return {{"mu_n", NumberOrNull(s.set.mu_n)},
          {"mu_t", NumberOrNull(s.set.mu_t)},
          {"eta_n", NumberOrNull(s.set.eta_n)},
          {"eta_t", NumberOrNull(s.set.eta_t)},
          {"E_mm", NumberOrNull(s.e)}};
}

Json PhaseJson(const PhaseSummary& p) {
  return {{"name", p.name},
          {"sets", p.sets},
          {"singular", p.singular},
          {"abandoned", p.abandoned},
          {"knots", p.knots},
          {"knots_full", p.knots_full},
          {"seconds", NumberOrNull(p.seconds)},
          {"best", SetJson(p.best)},
          {"termination", p.termination}};
}

// Evaluates one phase's sets in batches so progress and cancellation stay live, in
// the order of `passes`; with `abandon`, against the phase's running cut (keeping
// `percent` %), else every set to its end.
Status EvaluatePhase(BatchEvaluator& ev, int phase, const std::string& name, const std::vector<Coefficients>& sets,
                     double percent, bool abandon, const std::vector<ScreeningPass>& passes, std::vector<double>* e,
                     const EstimateHooks& hooks, PhaseSummary* summary) {
  const auto t0 = std::chrono::steady_clock::now();
  summary->name = name;
  summary->sets = static_cast<int64_t>(sets.size());
  e->assign(sets.size(), kInf);
  const size_t batch = std::max<size_t>(ev.parallelism() * 32, 256);
  RunningCut cut(KeepCount(sets.size(), percent));
  KnotCount knots;
  double best = kInf;
  int64_t done = 0;
  for (const ScreeningPass& pass : passes) {
    const std::vector<size_t> idx = pass(*e);
    for (size_t first = 0; first < idx.size(); first += batch) {
      if (hooks.cancelled && hooks.cancelled()) return Status::Cancelled("cancelled during " + name);
      const size_t count = std::min(batch, idx.size() - first);
      std::vector<Coefficients> part;
      part.reserve(count);
      for (size_t i = 0; i < count; ++i) part.push_back(sets[idx[first + i]]);
      std::vector<double> pe;
      EvaluationRequest req;
      req.phase = phase;
      req.cut = abandon ? &cut : nullptr;
      req.knots = &knots;
      req.progress = [&](int64_t d, int64_t) {
        if (hooks.progress) hooks.progress(name, done + d, summary->sets, best);
      };
      WORMDRAG_RETURN_IF_ERROR(ev.Evaluate(part, &pe, req));
      for (size_t i = 0; i < count; ++i) {
        (*e)[idx[first + i]] = pe[i];
        if (IsAbandoned(pe[i]))
          ++summary->abandoned;
        else if (!std::isfinite(pe[i]))
          ++summary->singular;
        best = std::min(best, pe[i]);  // NaN never wins: std::min keeps the first argument
      }
      done += static_cast<int64_t>(count);
      if (hooks.progress) hooks.progress(name, done, summary->sets, best);
    }
  }
  // The best in set order, as without abandoning (the first of equal E).
  best = kInf;
  for (size_t i = 0; i < sets.size(); ++i)
    if ((*e)[i] < best) {
      best = (*e)[i];
      summary->best = {sets[i], best};
    }
  summary->knots = knots.simulated;
  summary->knots_full = knots.full;
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Status::Ok();
}

// The best viscous set of the grid (μ_n = μ_t = 0), for Phase 3's extra start: the
// grid holds no law between pure viscous drag and v_c = Δμ / (N_max Δη) (10 mm/s by
// default, far above a crawling body's link speeds), so a mixed law is reachable only
// in Phase 3. From Coulomb-dominated survivors GRG can end on a pure Coulomb local
// minimum (η = 0); from a viscous set a Coulomb part grows continuously
// (docs/decisions/0041-viscous-start.md). Viscous sets that Phase 1 abandoned are
// evaluated here, against a cut of the best one known. Empty when none is simulable.
Result<std::optional<ScoredSet>> BestViscousSet(BatchEvaluator& screening, const std::vector<Coefficients>& grid,
                                                const std::vector<double>& e1) {
  std::vector<size_t> viscous, todo;
  double known = kInf;
  for (size_t i = 0; i < grid.size(); ++i) {
    if (grid[i].mu_n != 0 || grid[i].mu_t != 0) continue;
    viscous.push_back(i);
    if (IsAbandoned(e1[i]))
      todo.push_back(i);
    else
      known = std::min(known, e1[i]);
  }
  std::vector<double> e(grid.size(), kInf);
  for (size_t i : viscous) e[i] = e1[i];
  if (!todo.empty()) {
    std::vector<Coefficients> sets;
    for (size_t i : todo) sets.push_back(grid[i]);
    RunningCut cut(1, known);
    EvaluationRequest req;
    req.phase = 0;  // not Phase 1's record, which holds each grid set once: E or abandoned
    req.cut = &cut;
    std::vector<double> fresh;
    WORMDRAG_RETURN_IF_ERROR(screening.Evaluate(sets, &fresh, req));
    for (size_t k = 0; k < todo.size(); ++k) e[todo[k]] = fresh[k];
  }
  std::optional<ScoredSet> best;  // the first of equal E in grid order, as SelectBest ranks
  for (size_t i : viscous)
    if (!IsAbandoned(e[i]) && e[i] < (best ? best->e : kInf)) best = ScoredSet{grid[i], e[i]};
  return best;
}

}  // namespace

Status EstimateOptions::Validate() const {
  WORMDRAG_RETURN_IF_ERROR(eval.Validate());
  if (screening_substeps < 0 || screening_substeps > 1000)
    return Status::InvalidArgument("screening step (knots per frame) must be between 1 and 1000, or 0 for automatic");
  WORMDRAG_RETURN_IF_ERROR(search.Validate());
  WORMDRAG_RETURN_IF_ERROR(phase3.Validate());
  if (threads < 0 || threads > 1024) return Status::InvalidArgument("threads must be between 0 and 1024");
  return Status::Ok();
}

// Canonical key text, not a document for reading: the job store compares it as text to
// reuse jobs, so its bytes (%.17g numbers, this key order) are fixed.
std::string EstimateOptions::ToJson() const {
  char buf[700];
  std::snprintf(buf, sizeof buf,
                "{\"eval\":%s,\"screening_substeps\":%d,\"n_max\":%d,\"d_mu\":%.17g,\"d_eta\":%.17g,\"d1\":%.17g,"
                "\"d2\":%.17g,\"phase3\":\"%s\",\"fix_scale\":%s,\"grg_max_iterations\":%d,"
                "\"grg_gradient_tolerance\":%.17g,\"fd_step\":%.17g,\"max_evaluations\":%d,\"abandon\":%s}",
                eval.ToJson().c_str(), screening_substeps, search.n_max, search.d_mu, search.d_eta, search.d1,
                search.d2, Phase3MethodName(phase3.method), phase3.fix_scale ? "true" : "false",
                phase3.grg.max_iterations, phase3.grg.gradient_tolerance, phase3.grg.fd_step, phase3.max_evaluations,
                search.abandon ? "true" : "false");
  return buf;
}

RecordingFacts FactsOf(const PairedPath& pair) {
  RecordingFacts f;
  f.frame_interval = 1 / std::max(pair.worm(0).kinematics.fps, pair.worm(1).kinematics.fps);
  f.link_speed = std::min(MedianLinkSpeed(pair.worm(0).kinematics), MedianLinkSpeed(pair.worm(1).kinematics));
  return f;
}

// A few rounds: a fixed-scale refit may trade the tangential drag for other
// coefficients, so the check repeats, each round scaling up by the remaining excess.
Result<ScoredSet> BoundScaleOf(const ScoredSet& fit, const std::vector<ScoredSet>& restarts,
                               const SearchOptions& search, const Phase3Options& phase3, const RecordingFacts& facts,
                               BatchEvaluator& accurate, int64_t* sets) {
  ScoredSet best = fit;
  if (!(facts.frame_interval > 0)) return best;
  Phase3Options p3 = phase3;
  p3.fix_scale = true;
  for (int round = 0; round < 4; ++round) {
    const double tau = RelaxationTime(best.set, facts.link_speed);
    if (!(tau > facts.frame_interval)) break;
    // Without any tangential friction no scale relaxes: restart from `restarts`.
    std::vector<ScoredSet> starts = restarts;
    if (std::isfinite(tau)) {
      const Coefficients start = best.set.Scaled(tau / facts.frame_interval * (1 + 1e-9));
      std::vector<double> e;
      EvaluationRequest req;
      req.phase = 3;
      WORMDRAG_RETURN_IF_ERROR(accurate.Evaluate({start}, &e, req));
      starts = {{start, e[0]}};
    }
    PhaseSummary summary;
    auto refit = RunPhase3(starts, search, p3, accurate, &summary);
    if (!refit.ok()) return refit.status();
    best = *refit;
    if (sets) *sets += summary.sets;
  }
  return best;
}

namespace {

// The estimate refitted within the bound, and the note that says so.
Status BoundScale(BatchEvaluator& accurate, const EstimateOptions& o, const RecordingFacts& facts, EstimateResult* r) {
  const double tau0 = RelaxationTime(r->best.set, facts.link_speed), e0 = r->best.e;
  if (!(facts.frame_interval > 0 && tau0 > facts.frame_interval)) return Status::Ok();
  // The Phase 2 survivors lie on the grid's physical scale.
  auto bounded = BoundScaleOf(r->best, r->survivors2, o.search, o.phase3, facts, accurate, &r->phase3.sets);
  if (!bounded.ok()) return bounded.status();
  r->best = *bounded;
  r->scale_bound = ScaleBoundNote(tau0, facts.frame_interval, e0, r->best.e,
                                  RelaxationTime(r->best.set, facts.link_speed));
  return Status::Ok();
}

}  // namespace

Result<EstimateResult> RunEstimate(BatchEvaluator& screening, BatchEvaluator& accurate, const EstimateOptions& o,
                                   double body_length, const EstimateHooks& hooks, const RecordingFacts& facts) {
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  EstimateResult r;
  // Phase 1: the grid.
  const std::vector<Coefficients> grid = GridSets(o.search);
  std::vector<double> e1;
  WORMDRAG_RETURN_IF_ERROR(EvaluatePhase(screening, 1, "phase1", grid, o.search.d1, o.search.abandon,
                                         Phase1Passes(o.search), &e1, hooks, &r.phase1));
  r.survivors1 = SelectBest(grid, e1, o.search.d1);
  if (r.survivors1.empty()) return Status::FailedPrecondition("Phase 1: no coefficient set could be simulated");
  if (hooks.survivors) WORMDRAG_RETURN_IF_ERROR(hooks.survivors(1, r.survivors1));
  // Phase 2: half steps around the survivors.
  const std::vector<Coefficients> refined = RefinementSets(r.survivors1, o.search);
  std::vector<double> e2;
  WORMDRAG_RETURN_IF_ERROR(EvaluatePhase(screening, 2, "phase2", refined, o.search.d2, o.search.abandon,
                                         Phase2Passes(o.search, refined, r.survivors1), &e2, hooks, &r.phase2));
  r.survivors2 = SelectBest(refined, e2, o.search.d2);
  if (r.survivors2.empty()) return Status::FailedPrecondition("Phase 2: no coefficient set could be simulated");
  if (hooks.survivors) WORMDRAG_RETURN_IF_ERROR(hooks.survivors(2, r.survivors2));
  // Phase 3: local optimisation at full accuracy, from the survivors and, unless one of
  // them is viscous already, from the best viscous grid set.
  if (hooks.cancelled && hooks.cancelled()) return Status::Cancelled("cancelled before phase3");
  std::vector<ScoredSet> starts = r.survivors2;
  const bool has_viscous = std::any_of(starts.begin(), starts.end(),
                                       [](const ScoredSet& s) { return s.set.mu_n == 0 && s.set.mu_t == 0; });
  if (!has_viscous) {
    auto viscous = BestViscousSet(screening, grid, e1);
    if (!viscous.ok()) return viscous.status();
    if (*viscous) starts.push_back(**viscous);
  }
  if (hooks.progress) hooks.progress("phase3", 0, static_cast<int64_t>(starts.size()), r.survivors2[0].e);
  auto best = RunPhase3(starts, o.search, o.phase3, accurate, &r.phase3);
  if (!best.ok()) return best.status();
  r.best = *best;
  WORMDRAG_RETURN_IF_ERROR(BoundScale(accurate, o, facts, &r));
  r.e_percent = 100 * r.best.e / body_length;
  if (hooks.progress) hooks.progress("phase3", r.phase3.sets, r.phase3.sets, r.best.e);
  {
    std::vector<double> still;
    EvaluationRequest req;
    WORMDRAG_RETURN_IF_ERROR(accurate.Evaluate({StillBody()}, &still, req));
    r.still_e = still[0];
    r.still_e_percent = 100 * r.still_e / body_length;
    r.skill = std::isfinite(r.still_e) && r.still_e > 0 ? 1 - r.best.e / r.still_e : 0;
    r.explains_motion = r.skill >= o.min_skill;
  }
  if (hooks.progress) hooks.progress("identifiability", 0, 1, r.best.e);
  auto ident = AnalyseIdentifiability(accurate, r.best.set, r.best.e, body_length, o.identifiability);
  if (!ident.ok()) return ident.status();
  r.identifiability = std::move(*ident);
  if (hooks.progress) hooks.progress("identifiability", 1, 1, r.best.e);
  return r;
}

namespace {

// A relaxation time in words: a fit without tangential friction has no finite one.
std::string RelaxationText(double tau) {
  char buf[64];
  if (std::isfinite(tau))
    std::snprintf(buf, sizeof buf, "%.3g s", tau);
  else
    std::snprintf(buf, sizeof buf, "unbounded (no tangential friction)");
  return buf;
}

}  // namespace

std::string ScaleBoundNote(double tau_free, double frame_interval, double e_free, double e_bound, double tau_bound) {
  char buf[480];
  std::snprintf(buf, sizeof buf,
                "the free fit's relaxation time m/(eta_t + mu_t/v) was %s, longer than a frame interval (%.3g s), "
                "which a worm of this mass cannot have; refitted at fixed scale from the largest allowed (E %.4g -> "
                "%.4g mm, relaxation time now %s). The scale is not determined.",
                RelaxationText(tau_free).c_str(), frame_interval, e_free, e_bound, RelaxationText(tau_bound).c_str());
  return buf;
}

double RelaxationTime(const Coefficients& c, double link_speed, double link_mass) {
  const double drag = c.eta_t + (link_speed > 0 ? c.mu_t / link_speed : 0.0);
  return drag > 0 ? link_mass / drag : kInf;
}

double MedianLinkSpeed(const Kinematics& k) {
  std::vector<double> v;
  for (size_t f = 1; f < k.frames.size(); ++f) {
    const Frame &a = k.frames[f - 1], &b = k.frames[f];
    if (!a.valid || !b.valid || !(b.t > a.t)) continue;
    for (int i = 0; i < kNumLinks; ++i)
      v.push_back(0.5 * ((b.p[i] + b.p[i + 1]) - (a.p[i] + a.p[i + 1])).norm() / (b.t - a.t));
  }
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

Json EstimateResult::ToJson() const {
  Json j = {{"estimate", SetJson(best)},
            {"E_percent_BL", NumberOrNull(e_percent)},
            {"phases", Json::array({PhaseJson(phase1), PhaseJson(phase2), PhaseJson(phase3)})},
            {"identifiability", identifiability.ToJson()},
            {"still_body", {{"E_mm", NumberOrNull(still_e)}, {"E_percent_BL", NumberOrNull(still_e_percent)}}},
            {"skill", NumberOrNull(skill)},
            {"explains_motion", explains_motion}};
  if (!scale_bound.empty()) j["scale_bound"] = scale_bound;
  return j;
}

std::string EstimateResult::ToText() const {
  char buf[400];
  std::string s;
  std::snprintf(buf, sizeof buf,
                "estimate: mu_n = %.6g uN, mu_t = %.6g uN, eta_n = %.6g uN.s/mm, eta_t = %.6g uN.s/mm\n", best.set.mu_n,
                best.set.mu_t, best.set.eta_n, best.set.eta_t);
  s += buf;
  s += "  " + phase1.OneLineReport() + "\n  " + phase2.OneLineReport() + "\n  " + phase3.OneLineReport() + "\n";
  std::snprintf(buf, sizeof buf, "  a body that does not move: E = %.6g mm (%.4g %% BL); skill of the fit %.3f\n",
                still_e, still_e_percent, skill);
  s += buf;
  if (!scale_bound.empty()) s += "  scale: " + scale_bound + "\n";
  if (!explains_motion)
    return s + "The fit explains the motion no better than a body that does not move: no ratios are reported.\n";
  s += identifiability.ToText();
  return s;
}

}  // namespace wormdrag
