// How far a body travels along itself and sideways, measured against simulated, stretch
// by stretch (the simulated pose restarts from the measured one at each stretch: after
// gaps with --restart-after-gaps, every S seconds with --restart-every).
//
// A friction law acts through the body's own motion: it turns the shape changes into
// travel, mostly along the body (propulsion) and some across it (recoil). Where the
// recorded body also travels in a way that no law produces from its shapes (a medium
// that carries it, a force the model lacks), the stretches' velocities show which part
// of the travel the fit reproduces and which it misses. docs/real-data.md uses it on
// swimming worms that drift sideways.
#pragma once

#include <vector>

#include "core/common/status.h"
#include "core/estimate/paired_path.h"

namespace wormdrag {

struct StretchProgress {
  int worm = 0;           // 0 or 1
  double t0 = 0, t1 = 0;  // times of the stretch's first and last scored frame, s
  // The evaluation points' mean velocity over the stretch (their centroid's
  // displacement / (t1 − t0)), mm/s, projected on the stretch's mean body axis (from
  // the evaluation point nearest the tail to the one nearest the head, averaged over
  // the measured frames) and on that axis turned +90° in the recording's x-y axes.
  double measured_along = 0, measured_side = 0;
  std::vector<double> along, side;  // per coefficient set, the same projections of the simulated points
};

struct ProgressComparison {
  std::vector<Coefficients> sets;
  std::vector<StretchProgress> stretches;  // worm 0's, then worm 1's, in time order
};

// Stretches with fewer than 3 scored frames are left out (no travel to speak of).
// FAILED_PRECONDITION when a set does not simulate; INVALID_ARGUMENT for no set or fewer
// than two evaluation points (no body axis).
Result<ProgressComparison> CompareProgress(const PairedPath& pair, const std::vector<Coefficients>& sets);

// Mean and standard error over one worm's stretches of a per-stretch value, and the
// two-sided p-value of a zero mean (Student's t, n − 1 degrees of freedom; NaN for
// fewer than 2 stretches or no spread).
struct ProgressMean {
  int n = 0;
  double mean = 0, se = 0, p_zero = 0;
};
ProgressMean MeanOverStretches(const std::vector<double>& per_stretch);

}  // namespace wormdrag
