// The options of a diagnosis (RunDiagnosis) and the block and span constants they
// default to. Each threshold says what it controls and where its evidence is
// (docs/decisions/).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/fit_task.h"
#include "core/filter/shape_smoothing.h"

namespace wormdrag::diagnose {

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
  // 0 = none) or none. Default: auto, as the estimate smooths. The noise-only null is
  // right only with it: the low-pass removes gait harmonics the data have, and no null
  // made after it has them back, so the tests' false-alarm rate would not hold
  // (docs/decisions/0040-diagnosis-smooths-as-the-estimate.md).
  SmoothingMethod smoothing = SmoothingMethod::kAuto;
  double lowpass_hz = 5.0;
  SmoothingSplineOptions spline;  // for auto
  int interpolate_gaps = 0;       // fill runs of ≤ N missing frames first (0 = keep missing)
  // Time blocks per worm (held-out scoring); 0 = one per kBlockSeconds of the analysed
  // span (BlockCount).
  int blocks = 0;
  // Simulated noise-only recordings: the null every test of the verdict compares the
  // data with (false_alarm_rate). More replicates tighten the prediction bounds (the
  // Student-t factor at 5 % is 2.0 sd with 8 and 3.4 sd with 3) at one set of fits each.
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
  // The share of noise-only recordings in which each test of the verdict fires: the gap
  // test (the base's held-out score and its full path against the replicates' own), and
  // every effect's bar (its held-out reduction against the reductions it reaches on the
  // replicates). Each test compares the data with the one-sided (1 − rate) Student-t
  // prediction bound of a new draw from the replicates (PredictionBound; squared
  // distances on a log scale), so a right null gives this rate by construction
  // (docs/decisions/0039-false-alarm-rate.md). The two gap tests take half the rate
  // each, so that their union keeps it (docs/decisions/0049-one-rate-for-the-gap.md).
  // Default 0.05: one noise-only pair in twenty is called more than noise.
  double false_alarm_rate = 0.05;
  // Effects that remain below these stay unnamed although they clear their bar
  // (docs/decisions/0015-effect-bar.md): an effect must gain min_improvement of the
  // base's held-out score; effects within tie_fraction of the winner's gain tie with it;
  // a winner must remove explained_share of the held-out gap above the noise floor
  // (measured on its own refit, refine_top).
  double penalty_per_param = 0.01;  // CV score × (1 + this × extra parameters)
  double min_improvement = 0.12;    // relative CV gain an effect must at least reach
  double tie_fraction = 0.05;
  double explained_share = 0.7;
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
  // displacement there, beyond the change over as long a stretch elsewhere. Its z must
  // leave, on the fitted a's side, the two-sided (1 − false_alarm_rate) prediction
  // interval of the z that the noise-only replicates' base fits show. Without it a
  // gap_offset gain comes from another knob: a ≠ 0 also scales the path's progress as a
  // whole (in a 60 fps recording with a run of 2 dropped frames every 0.25 s, 3 of every
  // 15 frame intervals lie across a run, so a scales a fifth of the path). The replicates
  // set the interval because without the effect the mark's z is neither centred on 0 nor
  // standard normal (docs/decisions/0022-gap-signature.md,
  // docs/decisions/0045-gap-mark-bound-from-the-null.md).
  bool require_gap_signature = true;
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

}  // namespace wormdrag::diagnose
