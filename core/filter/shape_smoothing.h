// Smoothing of a recording's body shapes before they drive the model (docs/conventions.md §3).
//
// The joint angles of every run of consecutive valid frames are smoothed over time
// and each frame's points are rebuilt from the smoothed shape with the frame's own
// best-fit pose and link length, so the shape is smoothed and the path is not
// dragged. Two smoothers share this frame:
//   - auto (the default): a quintic smoothing spline per joint with λ chosen by GCV
//     from the recording itself (core/filter/smoothing_spline.h). Clean data come
//     out unchanged to within their rounding; noisy data lose the noise above the gait.
//   - the paper's 2nd-order Butterworth low-pass (core/filter/butterworth.h).
// Both report the tracking noise of the recording (TrackingNoiseByDifferences) and
// the RMS change they made to the points.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/common/json.h"
#include "core/common/status.h"
#include "core/filter/smoothing_spline.h"
#include "core/io/kinematics.h"

namespace wormdrag {

enum class SmoothingMethod { kAuto, kLowpass, kNone };
const char* SmoothingMethodName(SmoothingMethod m);
Result<SmoothingMethod> ParseSmoothingMethod(const std::string& name);

struct SmoothingReport {
  std::string method;  // what ran, in words
  int runs = 0;        // runs of valid frames smoothed
  int frames = 0;      // valid frames in them
  // The smoothing as a frequency: where the response of each joint's smoother falls
  // to ½ (Hz), median and range over the joints (or the shape modes above the
  // noise) and runs (0 when nothing was smoothed).
  double half_power_hz = 0, half_power_hz_min = 0, half_power_hz_max = 0;
  double noise_mm = 0;  // estimated tracking noise per coordinate (σ̂), mm
  // RMS change of a point coordinate by the smoothing, corrected for the degrees of
  // freedom of the rebuild (3 pose + 1 length per frame, tr H per joint and run), mm.
  double residual_mm = 0;
  double noise_percent_bl = 0;  // σ̂ in % of the body length
  std::string ToText() const;   // one line
  Json ToJson() const;
};

// The tracking noise per point coordinate (mm), from the high-order differences of
// the recorded coordinates over time: for white noise of SD σ, Δ^d x has SD
// σ·sqrt(C(2d, d)) while a smoothly moving body contributes ~ (ω/fps)^d. The median
// absolute difference makes it robust to glitches; the least of d = 3, 4, 5 keeps the
// motion's share small at low frame rates. 0 when no run has 6 frames.
double TrackingNoiseByDifferences(const Kinematics& k);

// f(series, joint) → the smoothed series, and the degrees of freedom it used
// (tr H for a linear smoother), the half-power frequency in cycles per sample.
struct SeriesSmoothing {
  std::vector<double> z;
  double dof = 0;
  double half_power = 0.5;
};
using SeriesSmoother = std::function<SeriesSmoothing(const std::vector<double>& series, int joint)>;

struct ShapeModes;

// What SmoothJointAngleRuns smooths besides the shapes.
struct RunSmoothing {
  // Series to smooth: the joint angles (nullptr) or these modes of them.
  const ShapeModes* modes = nullptr;
  // Also smooth each run's pose (x, y, q0) and link length over time, with the link
  // length corrected for the lengthening by noise (σ̂²/l per link). The pose starts
  // every simulated path and a few microradians of noise in its angle turn the whole
  // path; the paper's low-pass keeps each frame's own pose.
  bool pose = false;
};

// Applies `smooth` to every joint's (or mode's) unwrapped series in every run of
// valid frames and rebuilds the points; fills `report` (method is left to the caller).
// Series are numbered 0 … J−1 for joints or modes, then J … J+3 for x, y, q0 and
// the link length.
Kinematics SmoothJointAngleRuns(const Kinematics& k, const SeriesSmoother& smooth, SmoothingReport* report,
                                const RunSmoothing& what = {});

// The default smoother: GCV-chosen smoothing spline per joint and run.
Result<Kinematics> SmoothShapesAuto(const Kinematics& k, const SmoothingSplineOptions& opt, SmoothingReport* report);

}  // namespace wormdrag
