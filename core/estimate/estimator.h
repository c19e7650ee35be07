// The whole estimation (paper Block 2): Phase 1 grid → Phase 2 refinement → Phase 3
// GRG, then the identifiability report. Evaluations go through BatchEvaluators so the
// same driver runs embedded (threads) and on the coordinator (workers).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/estimate/identifiability.h"
#include "core/estimate/paired_path.h"
#include "core/estimate/search.h"

namespace wormdrag {

struct EstimateOptions {
  EvaluationOptions eval;  // E: points, t_max, solver, ε, substeps (Phase 3 and the report)
  // Phases 1–2 only rank sets: half the knot rate of eval (0 = automatic, 300 knots/s:
  // one per frame at 300 fps, within 2e-3 BL of the converged path).
  int screening_substeps = 0;
  SearchOptions search;  // N_max, Δμ, Δη, d1, d2
  Phase3Options phase3;  // method (grg), tolerances, fix_scale
  IdentifiabilityOptions identifiability;
  // A fit must beat a body that keeps its measured shapes but does not move (isotropic
  // drag: no thrust) by this share of that body's E before its ratios are reported.
  // Default: 0.5. A fit that halves the still body's error follows the motion; real
  // recordings without usable motion score near 0, clean fits near 1.
  double min_skill = 0.5;
  int threads = 0;  // 0 = all hardware threads
  Status Validate() const;
  std::string ToJson() const;  // canonical: every option, for the store and reuse
  EvaluationOptions ScreeningEval() const {
    EvaluationOptions e = eval;
    e.substeps = screening_substeps;
    e.knot_rate = eval.knot_rate / 2;
    return e;
  }
};

struct EstimateResult {
  ScoredSet best;        // E at full accuracy (eval.substeps)
  double e_percent = 0;  // E in % of the mean body length
  PhaseSummary phase1, phase2, phase3;
  std::vector<ScoredSet> survivors1, survivors2;
  IdentifiabilityReport identifiability;
  // The reference: E of a body that keeps its measured shapes but cannot propel
  // itself (isotropic viscous drag), and the skill 1 − E / E_still.
  double still_e = 0, still_e_percent = 0, skill = 0;
  bool explains_motion = true;  // skill ≥ options.min_skill
  // Set when the free fit's relaxation time exceeded a frame interval (a regime the
  // physics excludes) and the estimate was refitted at the largest allowed one.
  std::string scale_bound;
  Json ToJson() const;
  std::string ToText() const;
};

// The slowest velocity relaxation time of a link under friction c, s: m / (η_t + μ_t/v)
// for tangential sliding (the least resisted direction) at link speed v (mm/s).
double RelaxationTime(const Coefficients& c, double link_speed, double link_mass = kLinkMass);

// EstimateResult::scale_bound: the free fit's relaxation time and E, and the refit's
// at fixed scale (an unbounded time is said in words).
std::string ScaleBoundNote(double tau_free, double frame_interval, double e_free, double e_bound, double tau_bound);

// The median speed of the link centres over a recording's consecutive valid frames, mm/s.
double MedianLinkSpeed(const Kinematics& k);

// The still body's coefficients: equal normal and tangential drag, no Coulomb part.
inline Coefficients StillBody() {
  return {0, 0, 1, 1};
}

struct EstimateHooks {
  // Progress within a phase ("phase1", …): sets done of total and the best E so far.
  // Phase 3's starts run jointly, so it reports its start (0 of the starts) and its end
  // (every set it evaluated, done = total); identifiability reports 0 and then 1 of 1.
  std::function<void(const std::string& phase, int64_t done, int64_t total, double best_e)> progress;
  // The survivors of phase 1 or 2, once ranked.
  std::function<Status(int phase, const std::vector<ScoredSet>& ranked)> survivors;
  // Polled between batches; true stops the run with CANCELLED.
  std::function<bool()> cancelled;
};

// What the physics allows of a recording's fit: a link must relax to its friction
// within a frame interval, or the path would carry momentum across frames that a
// 5 µg worm cannot have (docs/estimation.md, "Scale").
struct RecordingFacts {
  double frame_interval = 0;  // s (0: no bound)
  double link_speed = 0;      // median link-centre speed, mm/s
};
RecordingFacts FactsOf(const PairedPath& pair);

// `fit` refitted at fixed scale (Phase 3 with fix_scale) from the smallest scale whose
// relaxation time fits in a frame interval, when its own is longer; `fit` itself
// otherwise. A fit without tangential friction relaxes at no scale and restarts from
// `restarts`. `sets`, if given, counts the sets evaluated.
Result<ScoredSet> BoundScaleOf(const ScoredSet& fit, const std::vector<ScoredSet>& restarts,
                               const SearchOptions& search, const Phase3Options& phase3, const RecordingFacts& facts,
                               BatchEvaluator& accurate, int64_t* sets = nullptr);

// `screening` evaluates with options.ScreeningEval(), `accurate` with options.eval.
// With `facts`, a Phase 3 result whose relaxation time exceeds a frame interval is
// refitted at fixed scale from the largest scale the bound allows.
Result<EstimateResult> RunEstimate(BatchEvaluator& screening, BatchEvaluator& accurate, const EstimateOptions& options,
                                   double mean_body_length, const EstimateHooks& hooks = {},
                                   const RecordingFacts& facts = {});

}  // namespace wormdrag
