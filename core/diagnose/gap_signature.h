// The signature of gap_offset in a base fit's residual (docs/conventions.md §5): across each run of
// missing frames the recorded body moves (1 + a) times what the model predicts there,
// so the base model's translation residual jumps by a × the model's own displacement
// over the run, and nowhere else. Without the effect the residual changes across a run
// as it does across any equally long stretch of valid frames (a base fit that predicts
// too little progress overall shows the same ratio everywhere). The excess of the ratio
// at the runs over the ratio elsewhere estimates a from the residual alone, with a
// standard error from the windows' spread: a check that a gap_offset gain comes from the
// dropped frames and not from a knob that scales the whole path.
#pragma once

#include <vector>

#include "core/model/body.h"
#include "core/model/friction_law.h"

namespace wormdrag::diagnose {

struct EffectData;
struct EffectRecording;
struct EffectTrajectory;

// One window between two valid frames: the change of the translation residual
// (measured − simulated centroid) and the simulated centroid's displacement, mm.
struct GapWindow {
  Vec2 residual_change = Vec2::Zero();
  Vec2 model_displacement = Vec2::Zero();
};

struct GapSignature {
  int gaps = 0;          // runs of missing frames with a valid frame on both sides
  int windows = 0;       // windows between valid frames elsewhere
  double at_gaps = 0;    // Σ Δr·Δc / Σ |Δc|² over the runs
  double elsewhere = 0;  // the same over the other windows
  double excess = 0;     // at_gaps − elsewhere: the gap offset the residual shows
  double se = 0;         // its standard error
  bool Measured() const { return gaps >= 2 && windows >= 2 && se > 0; }
  double Z() const { return Measured() ? excess / se : 0.0; }
};

// The ratio estimates and the standard error of their difference (the two sets are
// independent; each ratio's variance from its windows' residuals about it).
GapSignature SummariseGapWindows(const std::vector<GapWindow>& at_gaps, const std::vector<GapWindow>& elsewhere);

// The windows of one worm along its simulated continuous path `tr`: one per run of
// missing frames, and every window of as many frames between valid frames that touches
// no run. Appends to `at_gaps` and `elsewhere`.
void AddGapWindows(const EffectRecording& w, const EffectTrajectory& tr, std::vector<GapWindow>* at_gaps,
                   std::vector<GapWindow>* elsewhere);

// The windows of both worms of `d` under the base model `c`, each simulated here.
GapSignature MeasureGapSignature(const EffectData& d, const Coefficients& c, double eps);

}  // namespace wormdrag::diagnose
