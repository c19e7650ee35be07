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
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/effect_sim.h"
#include "core/diagnose/effects.h"
#include "core/diagnose/gap_signature.h"
#include "core/estimate/paired_path.h"
#include "core/filter/shape_smoothing.h"
#include "core/io/kinematics.h"

namespace wormdrag::diagnose {

// ---- Data and fits (the units of work; also used by the benchmark and tests) ----

// A recording prepared for effect fits: its drive, scored frames and time blocks.
struct EffectRecording {
  std::shared_ptr<const EffectDrive> drive;
  Kinematics kinematics;  // prepared (filtered, truncated); missing frames unscored
  struct Scored {
    int frame;  // recording frame
    int block;
    std::vector<Vec2> measured;  // per evaluation point, lab frame
    std::vector<Vec2> model;     // head frame
  };
  std::vector<Scored> frames;
  std::vector<int> block_starts;  // recording frames where blocks 1… start (pose resets)
  // With a subsampled fit (fit_hz): the full-rate prepared recording and, per frame of
  // `kinematics`, the index of its source frame in `full` (both empty otherwise).
  Kinematics full;
  std::vector<int> source_frames;
  // The prepared recording at the full frame rate, subsampled fit or not.
  const Kinematics& FullRate() const { return source_frames.empty() ? kinematics : full; }
};
struct EffectData {
  std::array<EffectRecording, 2> worms;
  double body_length = 0;
  int blocks = 0;
  // RMS change (rad) the smoothing made to the joint angles of the valid frames (0 when
  // unsmoothed). Beyond a noise-only replicate's, it is motion the smoothing took for
  // noise, which the drive loses and no catalogue effect restores ("where", smoothing).
  double smoothing_change_rad = 0;
};
// From kinematics already filtered and truncated to the analysed span; fit_hz > 0
// subsamples the frames as DiagnoseOptions::fit_hz describes.
Result<EffectData> PrepareEffectData(const std::array<Kinematics, 2>& k, const std::vector<int>& points, int substeps,
                                     int blocks, double fit_hz = 0);

// The frames a fit at `fit_hz` keeps (indices into k.frames): every
// round(fps / fit_hz)-th frame, every valid frame next to a missing one, the first
// missing frame of each run, and the last frame. All frames when fit_hz <= 0 or the
// stride is 1.
std::vector<int> FitFrames(const Kinematics& k, double fit_hz);

struct FitSpec {
  bool has_effect = false;
  Effect effect = Effect::kBodyGradient;
  std::vector<std::vector<double>> effect_starts;  // starting parameter vectors (per_worm: one set or both worms')
  Coefficients start;
  // Further coefficient starts, run in lockstep with `start` and pruned (each is
  // rescaled to start's coefficient sum: the overall scale is unobservable, §2).
  std::vector<Coefficients> extra_starts;
  // Ridge toward `prior`: one residual prior_weight × ln((u + δ) / (u_prior + δ)) per
  // coefficient (u in grid units at start's coefficient sum, δ = 2 % of that sum). It
  // keeps a fit on half the blocks from wandering along the valley of nearly equivalent
  // coefficient sets (DiagnoseOptions::cv_ridge). 0 = none.
  Coefficients prior;
  double prior_weight = 0;  // mm (the residuals are distances)
  bool blocked = true;      // pose restarts at block starts
  int train_parity = -1;    // fit on blocks with block % 2 == parity; -1 = all
  int iterations = 25;
  double epsilon = kDefaultEpsilon;
  int threads = 1;
  // Jacobian by forward differences (n + 1 simulations per iteration instead of
  // 2n + 1); Gauss–Newton converges as well with it on these fits
  // (docs/decisions/0012-fit-time-resolution.md).
  bool forward_differences = true;
  // The effect's parameters fitted separately for each worm (2 × its count; the
  // coefficients stay shared): does an effect of the medium act alike on both worms?
  // A measurement (`diagnose_bench --worm-check`); the diagnosis does not use it: the
  // split does not separate a tether from a true time_drift
  // (docs/decisions/0028-removed-experiments.md).
  bool per_worm = false;
};
struct FitOutcome {
  Coefficients coef;
  EffectParams effects;              // worm 1's when per_worm
  EffectParams second_worm_effects;  // worm 2's when per_worm (neutral otherwise)
  std::vector<double> params;        // per_worm: worm 1's, then worm 2's
  double train_mse = 0;
  long evaluations = 0;
};
// One fit of a diagnosis: on the data (replicate 0), or on noise-only replicate r ≥ 1
// simulated from `null_base` with tracking noise `null_sigma` (FitTaskData). The
// fits of a diagnosis are independent of each other once the base fit is known, so
// they can run anywhere: on local threads, or as tasks on the service's workers.
struct FitTask {
  int replicate = 0;
  Coefficients null_base;
  double null_sigma = 0;
  FitSpec spec;
};
// Runs fits and returns their outcomes in the order given.
using FitRunner = std::function<Result<std::vector<FitOutcome>>(const std::vector<FitTask>&)>;

// The default block length of the held-out scoring: every benchmark figure is measured
// with it, and longer blocks raise every held-out E (docs/decisions/0010-held-out-blocks.md).
// Shorter blocks restart the pose more often, which leaves less of the path's drift to score.
inline constexpr double kBlockSeconds = 0.5;
inline constexpr int kMinBlocks = 2, kMaxBlocks = 100;  // two folds need two blocks
// The shortest recording per worm the benchmark finds reliable: on the same pairs the
// verdicts are right far less often at 2 s per worm than at 5 s
// (docs/decisions/0011-recording-length.md). A shorter analysed span is diagnosed but
// carries a caution.
inline constexpr double kReliableSpanSeconds = 5.0;

struct DiagnoseOptions {
  std::vector<int> points = {3, 7, 10};  // evaluation points of the fits (the paper's)
  double t_max = 5.0;                    // analysed span, s
  double epsilon = kDefaultEpsilon;      // smooth-sign width, mm/s
  int substeps = 2;                      // solver knots per fitted-frame interval
  // Time resolution of the fits, decoupled from the frame rate: the fits simulate and
  // score a subsample of the (low-passed) frames, every round(fps / fit_hz)-th frame
  // plus the frames bordering each run of missing frames (0 = every frame). Knots per
  // second = fit_hz × substeps. The null replicates are still generated, noised and
  // filtered at the full frame rate (docs/decisions/0012-fit-time-resolution.md).
  double fit_hz = 30;
  // Smoothing of the recordings before they drive and score the fits, as the estimate
  // offers it (core/filter/shape_smoothing.h): auto (a smoothing spline per shape mode
  // chosen by GCV), lowpass (the paper's Butterworth on the joint angles at lowpass_hz;
  // 0 = none) or none. Default: lowpass, the setting every verdict figure of the
  // diagnosis benchmark was measured with (BENCHMARKS.md). With auto, a null made from
  // clean shapes is right and with lowpass it is not (docs/diagnose.md, "How far the
  // null is from right").
  SmoothingMethod smoothing = SmoothingMethod::kLowpass;
  double lowpass_hz = 5.0;
  SmoothingSplineOptions spline;  // for auto
  int interpolate_gaps = 0;       // fill runs of ≤ N missing frames first (0 = keep missing)
  // Time blocks per worm (held-out scoring); 0 = one per kBlockSeconds of the analysed
  // span (BlockCount).
  int blocks = 0;
  // Simulated noise-only recordings. An effect's bar is their mean gain + null_z sd, and
  // an sd from a handful of replicates is erratic (docs/decisions/0014-null-replicates.md).
  int null_replicates = 8;
  double noise_sigma = -1;           // tracking noise σ, mm per coordinate; < 0 = estimate
  std::vector<std::string> effects;  // catalogue effects to test; empty = all eight
  int threads = 0;                   // 0 = all hardware threads
  bool base_grid = true;             // base fit by the paper's Phases 1–3; false: GRG from `start`
  Coefficients start{0.5, 0.2, 0.005, 0.002};
  int grg_iterations = 10;    // per effect fit (Gauss–Newton converges in a few)
  int base_iterations = 150;  // the base fit by GRG (base_grid false): the effect fits start from it
  // The GRG base fit (base_grid false) and the blocked refit below also start from the
  // corners of a box around their start (BaseStarts: normal/tangential ratios and the
  // Coulomb/viscous balance moved), pruned after 4 iterations. Insurance against a lone
  // start's local minimum (docs/decisions/0013-blocked-refit-and-ridge.md).
  bool base_multistart = true;
  // The CV's fold fits (and the null replicates) start from the base refitted with
  // blocked paths on all blocks, and are held near it by a ridge of weight
  // cv_ridge × √2 σ (FitSpec::prior_weight): a factor e in one coefficient costs
  // cv_ridge² × the noise's own mean squared distance. Without it, fits on half the
  // blocks wander along the valley of nearly equivalent coefficient sets, score worse on
  // the other half than the true model, and any effect that pulls them back looks
  // significant (docs/decisions/0013-blocked-refit-and-ridge.md). 0 = no ridge.
  double cv_ridge = 0.5;
  // How far: the refine_top effects with the best CV scores are refitted with all blocks
  // and free coefficients, and their held-out E is measured by fold fits started from
  // and held near that fit (EffectFit::own_*): the base-centred fold fits cannot undo
  // the base's compensation for the missing effect (docs/decisions/0019-own-refit.md).
  // 0 = report the base-centred E.
  int refine_top = 1;
  uint64_t seed = 20240607;  // null noise and bootstrap
  // Verdict thresholds, tuned on the benchmark's synthetic pairs and scored on fresh ones
  // (docs/decisions/0015-effect-bar.md). An effect's bar is max(min_improvement,
  // null mean + null_z null sd, null_mean_ratio null mean); effects within tie_fraction of
  // the winner's gain tie with it; a winner must remove explained_share of the held-out
  // gap above the noise floor (measured on its own refit, refine_top).
  double penalty_per_param = 0.01;  // CV score × (1 + this × extra parameters)
  double min_improvement = 0.12;    // relative CV gain an effect must at least reach
  double null_z = 6.0;
  double tie_fraction = 0.05;
  double explained_share = 0.7;
  // Base CV / noise floor above which a gap exists (else the verdict without a significant
  // effect is `none`, and the explained share is not required). Large because the
  // noise-only floor is optimistic: on `none` pairs the TRUE model's held-out MSE is up
  // to about 5.6× a replicate's (docs/decisions/0020-excess-ratio.md). The same ratio,
  // applied to the base fit's unrestarted full path against the replicates' full paths,
  // keeps a model that drifts beyond the noise from being called `none`: restarting
  // every block hides a misfit that accumulates along the path
  // (docs/decisions/0036-full-path-gap.md).
  double excess_ratio = 5;
  // An effect's bar is at least this multiple of its mean gain on the noise-only
  // replicates (0 = off). The replicates reproduce the processing's bias only in part:
  // their truth is driven by the data's processed shapes, which already carry the
  // filtered tracking noise, so fresh noise slows their model less than the data's
  // (docs/decisions/0014-null-replicates.md), and the data's spurious gains run to two or
  // three times the replicates' mean (docs/decisions/0016-null-mean-ratio.md).
  double null_mean_ratio = 3;
  // An effect is significant only if, besides clearing its bar, the 90 % paired
  // block-bootstrap interval of its held-out shrink lies above 0 (its gain is not one
  // or two lucky blocks). Independent of the null floor's calibration
  // (docs/decisions/0017-shrink-interval.md).
  bool require_shrink_interval = true;
  // An effect's fold fit that ends with a higher training error than the base model's
  // fit on the same fold is replaced by that base fit with the effect neutral (a point
  // of the effect model, since it nests the base): the optimiser got lost, and its end
  // point would count against the effect on the held-out blocks
  // (docs/decisions/0018-nested-fallback.md).
  bool nested_fallback = true;
  // Simulation–extrapolation (SIMEX) check of the leading effects. The tracking noise
  // left in the joint angles that drive the model biases its fits: a model driven by
  // noisy shapes falls behind the body, and gap_offset or flow take that up even where
  // nothing is missing; the noise-only replicates carry only about a third of that bias
  // (docs/decisions/0021-simex-check.md). So the `simex_top` effects with the best CV scores
  // are fitted again (base and effect, both folds) on `simex_draws` copies of the data
  // with tracking noise of the estimated σ added (noise variance doubled, λ = 1); an
  // effect the data score by its own fit (score_refined_fit) is also fitted there from
  // that fit, and scored by the better of the two, as on the data. An
  // artefact of the noise gains more there; an effect in the data gains about as much.
  // The effect's gain, extrapolated back toward no noise, is
  //   improvement − simex_weight × max(0, median gain on the noisy copies − improvement)
  // (gains as base score − effect score over the data's base score; weight 1 is the
  // linear extrapolation to λ = −1), and it must clear the effect's bar too.
  // simex_weight 0 = off (the check's fits still run, and are reported, when
  // simex_draws > 0). With the check on, an effect it did not examine (ranked below
  // simex_top) cannot be named. A larger weight also rejects real effects whose gain
  // rises with the noise because the drive's bias adds to it.
  int simex_draws = 3;
  int simex_top = 2;
  double simex_weight = 1;
  // The other side of the same check: an effect of the body gains about as much on the
  // noisy copies as on the data, so an effect is significant only if its median gain
  // there is at least simex_min_keep × its gain on the data: a gain that all but
  // vanishes there fits the chance pattern of this recording's noise. 0 = off.
  double simex_min_keep = 0.3;
  // Score an effect refined with free coefficients (refine_top) by the better of its
  // base-centred fold fits and those centred on its own fit (EffectFit::scored_own):
  // the base-centred fits cannot undo the base's compensation for the missing effect.
  // The own fold fits start from a fit that saw every block, so their held-out score is
  // slightly optimistic; the start (the basin) is what they change
  // (docs/decisions/0019-own-refit.md).
  bool score_refined_fit = true;
  // gap_offset is named only where the base fit's residual shows its signature
  // (gap_signature.h): a jump at the runs of missing frames, along the model's own
  // displacement there, beyond the change over as long a stretch elsewhere, of at
  // least this many standard errors and of the fitted a's sign. Without it a gap_offset
  // gain comes from another knob: a ≠ 0 also scales the path's progress as a whole
  // (in a 60 fps recording with a run of 2 dropped frames every 0.25 s, 3 of every 15
  // frame intervals lie across a run, so a scales a fifth of the path). 0 = off
  // (docs/decisions/0022-gap-signature.md).
  double gap_signature_z = 3;
  // An effect whose fits all left its parameters at a starting value
  // (EffectFit::estimated false) is never the verdict: the verdict gives the effect's
  // parameter with an interval, and this one was not estimated. Stiction's fits do this
  // (its held-out E is jagged in a on the scale of the fit's difference step, so the
  // gradient there says nothing), with intervals as tight as if it had been estimated
  // (docs/decisions/0023-unestimated-parameters.md).
  bool require_estimated_params = true;
  // How sure a named effect is (Diagnosis::confidence): *clear* when its held-out gain,
  // and its gain extrapolated to no noise (SIMEX), are both at least clear_margin × the
  // bar that noise-only refits set; *tentative* otherwise: an effect that only just clears
  // its bar is where the wrong names are (docs/decisions/0024-verdict-grade.md). It changes
  // no verdict. Must be ≥ 1.
  double clear_margin = 2;
  // Progress (stage, fraction 0…1) and cancellation; both may be empty.
  std::function<void(const std::string& stage, double fraction)> progress;
  std::function<bool()> cancelled;
  // Runs the effect and null fits (the bulk of the work); empty = on `threads` local
  // threads. The coordinator sets it to hand the fits to workers.
  FitRunner run_fits;
  Status Validate() const;
};

// One cell of the "where" breakdown: the data's value and the noise-only null's.
struct BreakdownCell {
  std::string label;
  double value = 0;                   // mm (or rad for heading)
  double null_mean = 0, null_hi = 0;  // null mean and mean + 2 sd
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
  Coefficients base;                  // base fit (continuous path, the paper's E)
  Coefficients cv_base;               // the base refitted on blocked paths: the CV's start and ridge centre
  double base_e_mm = 0;
  // where
  std::vector<Breakdown> where;
  std::vector<std::vector<double>> residual_t, residual_mm;  // per worm: time and mean distance per frame
  // which
  EffectFit base_cv;  // the base model's CV score
  std::vector<EffectFit> effects;
  double null_base_cv_mse = 0, null_base_cv_sd = 0, null_base_cv_e = 0;  // noise floor
  // Per worm, the raw shapes' residual variance about a periodic gait over the noise's
  // (NullTruth): at most kMaxGaitExcess, the replicates simulate the gait, else the
  // prepared shapes. Infinite when not measured.
  std::array<double, 2> null_gait_excess = {std::numeric_limits<double>::infinity(),
                                            std::numeric_limits<double>::infinity()};
  bool NullUsesGait(int j) const { return null_gait_excess[j] <= kMaxGaitExcess; }
  std::vector<double> simex_base_mse;  // the base model's held-out MSE on each noisy copy (SIMEX check)
  bool gap_beyond_noise = false;
  // The base fit's continuous path over all points and valid frames (mean squared
  // distance, mm²) and the same on the noise-only replicates' own base fits (mean, sd;
  // 0 without replicates). path_beyond_noise: above excess_ratio × that mean and
  // null_z sd, so the verdict cannot be `none`.
  double path_mse = 0, null_path_mse = 0, null_path_sd = 0;
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

Result<FitOutcome> FitModel(const EffectData& data, const FitSpec& spec);
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
// dashed mean + 2 sd). The diagnosis page and the job report both draw it.
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

// Sums of distances and squared distances over the frames of the given blocks
// (parity −1: all), per block, for a model.
struct BlockScores {
  std::vector<double> sum, sum_sq;  // per (worm, block): index worm * blocks + block
  std::vector<int> count;
};
BlockScores ScoreBlocks(const EffectData& data, const Coefficients& c, const EffectParams& p, bool blocked,
                        double epsilon);

// One noise-only null recording (what RunDiagnosis's replicates use): model `c` (no
// effect) simulated on w's prepared joint angles, at w's full frame rate with its
// missing frames, plus Gaussian tracking noise σ (seeded). Not yet filtered.
Result<Kinematics> NullRecording(const EffectRecording& w, const Coefficients& c, double eps, double sigma,
                                 uint64_t seed);

}  // namespace wormdrag::diagnose
