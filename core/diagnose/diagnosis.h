// The sim-to-real gap diagnosis (docs/diagnose.md; the effect catalogue is
// docs/conventions.md §5): where the residual of the base fit lies, which catalogue effect
// explains it, and how far held-out E shrinks once it is added.
//
// Method, stage by stage (each default's evidence: docs/decisions/):
//  - Preparation: truncate, interpolate short gaps for the filter, low-pass the joint
//    angles, subsample the frames the fits use (fit_hz).
//  - Base fit: the paper's three phases (RunEstimate, quasi-static) or GRG; then a refit on
//    blocked paths, the start and ridge centre of every held-out fit.
//  - Held-out scoring: each worm's span is cut into time blocks; the pose restarts from the
//    measured one at each block start; two folds (even / odd blocks), fitted on one and
//    scored on the other. CV score = held-out mean squared distance (mm²) ×
//    (1 + penalty_per_param × extra parameters). Quasi-static throughout (scale-free;
//    inertia's signal is ~1e-6 BL), with the effect-aware simulator of effect_sim.h.
//  - Null: noise-only recordings simulated from the blocked refit plus tracking noise of
//    the estimated σ, put through the same pipeline. They give the noise floor of every
//    "where" cell and of the base CV score, and each effect's bar.
//  - SIMEX check: the leading effects refitted on copies of the data with noise added.
//  - Verdict (Decide): an effect is significant when its gain clears its bar, its
//    held-out shrink is positive in a paired block bootstrap, it passes the SIMEX check,
//    its parameter was estimated, and (gap_offset) the base residual shows its mark. The
//    best wins unless others tie; too small a share of the gap gives `unexplained`; no
//    significant effect gives `none` or `unexplained` by the size of the gap.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/effects.h"
#include "core/diagnose/fit_task.h"
#include "core/diagnose/gap_signature.h"
#include "core/diagnose/options.h"
#include "core/io/kinematics.h"

namespace wormdrag::diagnose {

// One cell of the "where" breakdown: the data's value and the noise-only null's.
struct BreakdownCell {
  std::string label;
  double value = 0;  // mm (or rad for heading)
  // The noise-only replicates' mean and the prediction bound of a new draw from them
  // (DiagnoseOptions::false_alarm_rate; infinite without two replicates).
  double null_mean = 0, null_hi = 0;
  bool above_noise() const { return value > null_hi; }
};
struct Breakdown {
  std::string name, units;
  std::vector<BreakdownCell> cells;
};

struct EffectFit {
  std::string name;
  std::vector<std::string> param_names;
  int extra_params = 0;
  bool testable = true;  // false: the data cannot show it (e.g. gap_offset without gaps)
  std::string note;
  // Refined (DiagnoseOptions::refine_top): the all-block fit with free coefficients.
  // Otherwise the coefficients of the first fold fit and the mean of the folds' parameters.
  Coefficients coef;
  std::vector<double> params, param_lo, param_hi;  // estimate and interval
  // False when every fit the estimate comes from ended where it started, within
  // kUnmovedUnits grid units of a starting value (StayedAtStart): the data did not move
  // the parameters, so `params` is a start and param_lo/param_hi span the admissible range.
  bool estimated = true;
  std::vector<double> null_param_sd;                 // spread of the estimate on noise-only data
  double cv_mse = 0, cv_score = 0;                   // held-out mean squared distance (mm²), penalised
  double cv_e_mm = 0;                                // held-out mean distance (mm)
  double improvement = 0;                            // 1 − score / base score
  double null_mean = 0, null_sd = 0, threshold = 0;  // of the improvement on noise-only data
  double shrink_lo = 0;                              // 5 % quantile of the paired block-bootstrap held-out shrink (mm)
  bool significant = false;
  std::vector<double> block_sum, block_count;  // held-out distance sums per (worm, block)
  std::vector<double> null_improvements;       // on each noise-only replicate: MSE / the base's
  // SIMEX check (DiagnoseOptions::simex_*; the leading effects only, else empty): the
  // effect's held-out MSE on each noisy copy of the data, and from Decide the median
  // gain there and the extrapolated gain that must clear the bar.
  std::vector<double> simex_mse;
  // A refined effect's held-out MSE on each noisy copy from fold fits started from and
  // held near its own fit on the data (empty otherwise): when the data score it by its
  // own fit (scored_own), the copies score it by the better of the two as well.
  std::vector<double> simex_own_mse;
  double simex_gain = 0, simex_corrected = 0;
  // The model error the effect leaves, over the base model's (SIMEX-extrapolated to no
  // noise; NaN when not checked or when the base shows none).
  double simex_residual = std::numeric_limits<double>::quiet_NaN();
  // Held-out scores of fold fits centred on the effect's own all-block fit (refined
  // only; the held-out frames, hence block_count, are the same). They give "how far".
  bool refined = false;
  double own_cv_mse = 0, own_cv_e_mm = 0;
  std::vector<double> own_block_sum;
  bool scored_own = false;  // cv_score and shrink_lo come from the own fold fits (Decide)
};

// NullTruth's bound on a worm's residual variance about a periodic gait, over the
// noise's, for the replicates to simulate the gait. The ratio is 1.0–1.15 on a steady
// wave and 3.8–86 on real worms' kymograms (the benchmark's sets 11, 95 and 97); 2 leaves
// room on both sides (docs/decisions/0038).
inline constexpr double kMaxGaitExcess = 2;

struct Diagnosis {
  std::array<std::string, 2> names;
  double body_length = 0, noise_sigma = 0, gait_hz = 0;
  bool noise_estimated = true;
  double span_s = 0;                  // analysed time per worm (the shorter recording's frames × 1/fps, ≤ t_max), s
  int blocks = 0;                     // held-out blocks per worm (BlockCount)
  std::vector<std::string> cautions;  // what limits how far the verdict can be trusted (plain language)
  GapSignature gap_signature;         // gap_offset's mark in the base fit's residual (where; gap_signature.h)
  // The mark's z on each noise-only replicate's own base fit (those where it was
  // measured), and their two-sided (1 − false_alarm_rate) prediction interval, which the
  // data's z must leave on the fitted a's side (DiagnoseOptions::require_gap_signature);
  // infinite without two.
  std::vector<double> null_gap_z;
  double gap_signature_lo = -std::numeric_limits<double>::infinity();
  double gap_signature_hi = std::numeric_limits<double>::infinity();
  Coefficients base;     // base fit (continuous path, the paper's E)
  Coefficients cv_base;  // the base refitted on blocked paths: the CV's start and ridge centre
  double base_e_mm = 0;
  // where
  std::vector<Breakdown> where;
  std::vector<std::vector<double>> residual_t, residual_mm;  // per worm: time and mean distance per frame
  // which
  EffectFit base_cv;  // the base model's CV score
  std::vector<EffectFit> effects;
  double null_base_cv_mse = 0, null_base_cv_sd = 0, null_base_cv_e = 0;  // noise floor
  std::vector<double> null_base_cv_mses;  // the base's held-out MSE on each noise-only replicate
  // Per worm, the raw shapes' residual variance about a periodic gait over the noise's
  // (NullTruth): at most kMaxGaitExcess, the replicates simulate the gait, else the
  // prepared shapes. Infinite when not measured.
  std::array<double, 2> null_gait_excess = {std::numeric_limits<double>::infinity(),
                                            std::numeric_limits<double>::infinity()};
  bool NullUsesGait(int j) const { return null_gait_excess[j] <= kMaxGaitExcess; }
  std::vector<double> simex_base_mse;  // the base model's held-out MSE on each noisy copy (SIMEX check)
  bool gap_beyond_noise = false;
  // The prediction bounds (mm², each at half DiagnoseOptions::false_alarm_rate) the
  // base's held-out MSE and its full path's are tested against; infinite without two
  // replicates.
  double noise_bound_cv_mse = 0, noise_bound_path_mse = 0;
  // The base fit's continuous path over all points and valid frames (mean squared
  // distance, mm²) and the same on the noise-only replicates' own base fits (mean, sd;
  // 0 without replicates). path_beyond_noise: above the replicates' prediction bound
  // (noise_bound_path_mse), so the verdict cannot be `none`.
  double path_mse = 0, null_path_mse = 0, null_path_sd = 0;
  std::vector<double> null_path_mses;  // each replicate's own base fit's full-path MSE
  bool path_beyond_noise = false;
  std::string verdict;  // effect name, "none", "unexplained", or "a|b" (indistinguishable)
  std::vector<std::string> verdict_set;
  std::string closest;      // unexplained: the effect that came closest
  std::string explanation;  // one paragraph, plain language
  // A named effect (or set): "clear" or "tentative" (DiagnoseOptions::clear_margin);
  // empty for `none` and `unexplained`. margin: the named effect's smaller of gain and
  // SIMEX-corrected gain over its bar.
  std::string confidence;
  double margin = 0;
  // how far (held-out, mm and % BL; 90 % block-bootstrap intervals)
  double e_before = 0, e_after = 0, e_before_lo = 0, e_before_hi = 0, e_after_lo = 0, e_after_hi = 0;
  double shrink_mm = 0, shrink_lo = 0, shrink_hi = 0;
  double share_of_gap = 0;  // of the held-out gap above the noise floor
  double seconds = 0;
  std::string ToJson() const;
  std::string ToText() const;
  std::string ToHtml() const;
};

// Decides the verdict and "how far" from the scores already in `d` (thresholds from
// `o`): RunDiagnosis calls it; the benchmark re-runs it to tune the thresholds.
void Decide(const DiagnoseOptions& o, Diagnosis* d);

// The blocks per worm for an analysed span of `span_s` seconds: o.blocks when set,
// else round(span / kBlockSeconds), kMinBlocks … kMaxBlocks.
int BlockCount(const DiagnoseOptions& o, double span_s);

// Runs the whole diagnosis of a pair of recordings.
Result<Diagnosis> RunDiagnosis(const std::array<Kinematics, 2>& recordings, const std::array<std::string, 2>& names,
                               const DiagnoseOptions& options);

// Tracking noise σ (mm per coordinate) from the second differences of every point
// over consecutive valid frames (robust: median absolute deviation).
double EstimateTrackingNoise(const Kinematics& k);

// ---- Lower-level pieces (exposed for the benchmark and tests) ----

// The truth the noise-only replicates simulate, from the raw `recordings` and their
// prepared `data`: per worm, the prepared shapes replaced by a periodic gait (per joint a
// line plus three harmonics of the middle joint's frequency, fitted to them) when the raw
// shapes' residual variance about that gait is at most `max_excess` × the noise variance
// GCV finds in the residual; the prepared shapes otherwise. Smoothing leaves part of the
// noise in the shapes, and a replicate simulated on them takes that part for motion, so on
// an exactly regular gait the replicates fit better than the data do; a gait that is not
// periodic has no such regular truth to offer (docs/decisions/0038). excess[j]: worm j's
// ratio (infinite when too few frames to fit a gait).
Result<EffectData> NullTruth(const std::array<Kinematics, 2>& recordings, const EffectData& data,
                             const DiagnoseOptions& o, double max_excess = kMaxGaitExcess,
                             std::array<double, 2>* excess = nullptr);
// The starting parameter vectors the diagnosis uses for an effect (the neutral value,
// plus a second start for the laws whose fits have more than one basin).
std::vector<std::vector<double>> EffectStarts(Effect e);
// Within this many grid units (EffectInfo::unit) of its start a fitted parameter has not
// moved: ten central-difference steps (1e-3 units each). A fit stuck on a jagged error
// still takes a few tiny steps: on the real recording both stiction folds end within
// about 7e-3 units of their start 2, against an interval of ±15 units
// (docs/decisions/0023-unestimated-parameters.md).
inline constexpr double kUnmovedUnits = 1e-2;
// Whether a fit of effect e that was given `starts` ended at one of them: every parameter
// of `params` (one set, or the worms' sets one after the other) within kUnmovedUnits grid
// units of the same start.
bool StayedAtStart(Effect e, const std::vector<double>& params, const std::vector<std::vector<double>>& starts);

// An effect's parameters as reported: "name = value [lo, hi]" each, ", "-separated; a
// parameter its fits never moved (EffectFit::estimated false) reads "name = value (not
// estimated: its fits stayed at a start)", since its interval would only be the
// admissible range.
std::string ParameterText(const EffectFit& e);
// The verdict as shown to a user: "lag", or "lag (tentative)" when it carries a grade
// (Diagnosis::confidence). Shared by the text, HTML and stored-result views.
std::string VerdictLabel(const std::string& verdict, const std::string& confidence);

// One "where" breakdown as an inline SVG bar chart: the residual of each part (red above
// what tracking noise alone gives) against the noise-only refits (blue: solid mean,
// dashed their prediction bound). The diagnosis page and the job report both draw it.
std::string BreakdownSvg(const Breakdown& b);
// The further starts of the GRG base fit around `c` (DiagnoseOptions::base_multistart).
std::vector<Coefficients> BaseStarts(const Coefficients& c);

// The recordings prepared exactly as RunDiagnosis prepares them (truncation to the
// common span, gap handling, filter, blocks).
Result<EffectData> PrepareForDiagnosis(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o);

// The data a FitTask runs on: the recordings prepared as PrepareForDiagnosis does
// (replicate 0), noise-only replicate `replicate` (1 … null_replicates) made from them,
// or, for replicate null_replicates + 1 + d, the SIMEX check's noisy copy d of the
// recordings (tracking noise `null_sigma` added). Deterministic: a worker rebuilds
// exactly the data the coordinator scores.
Result<EffectData> FitTaskData(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o, int replicate,
                               const Coefficients& null_base, double null_sigma);

// One noise-only null recording (what RunDiagnosis's replicates use): model `c` (no
// effect) simulated on w's prepared joint angles, at w's full frame rate with its
// missing frames, plus Gaussian tracking noise σ (seeded). Not yet filtered.
Result<Kinematics> NullRecording(const EffectRecording& w, const Coefficients& c, double eps, double sigma,
                                 uint64_t seed);

}  // namespace wormdrag::diagnose
