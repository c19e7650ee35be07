// The paper's smoothing of joint angles (docs/conventions.md §3): a 2nd-order Butterworth low-pass,
// cut-off 5 Hz, designed by the bilinear transform with the cut-off prewarped, so the
// digital filter is exactly −3 dB at fc. Applied forward and backward (zero phase, like
// SciPy's filtfilt with odd-reflection padding) by default, forward only as an option.
#pragma once

#include <complex>
#include <vector>

#include "core/common/status.h"
#include "core/filter/shape_smoothing.h"
#include "core/io/kinematics.h"

namespace wormdrag {

// y[n] = b0 x[n] + b1 x[n−1] + b2 x[n−2] − a1 y[n−1] − a2 y[n−2]
struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
  std::complex<double> Response(double f_hz, double fs_hz) const;  // H(e^{iωT})
};

// Requires 0 < cutoff < fs/2.
Result<Biquad> ButterworthLowPass2(double cutoff_hz, double fs_hz);

// Forward filtering from the steady state of the first sample (SciPy's lfilter with
// zi = lfilter_zi·x[0]), so a constant signal passes unchanged with no start-up transient.
std::vector<double> FilterCausal(const Biquad& f, const std::vector<double>& x);

// Forward–backward filtering with odd reflection padding of min(9, n−1) samples at each
// end (SciPy's default padlen = 3·max(len(a), len(b))): zero phase, magnitude |H|².
// Fewer than 2 samples are returned unchanged.
std::vector<double> FiltFilt(const Biquad& f, const std::vector<double>& x);

struct AngleFilterOptions {
  double cutoff_hz = 5.0;
  bool zero_phase = true;  // false: causal (forward only), delays the angles
};

// Low-pass filters the 12 joint angles of every frame over time and rebuilds the points
// with each frame's own best-fit pose (x, y, q0) and link length, so only the shape is
// smoothed. Missing frames stay missing: each run of consecutive valid frames is filtered
// separately (interpolate short gaps first, core/io/gaps.h, to filter across them).
// Angles are unwrapped over time within a run before filtering.
// `report`, if given, receives what ran and the tracking noise it saw.
Result<Kinematics> FilterJointAngles(const Kinematics& k, const AngleFilterOptions& opt,
                                     SmoothingReport* report = nullptr);

}  // namespace wormdrag
