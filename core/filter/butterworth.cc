#include "core/filter/butterworth.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace wormdrag {

std::complex<double> Biquad::Response(double f_hz, double fs_hz) const {
  const std::complex<double> z1 = std::polar(1.0, -2 * M_PI * f_hz / fs_hz);  // z^{-1}
  return (b0 + b1 * z1 + b2 * z1 * z1) / (1.0 + a1 * z1 + a2 * z1 * z1);
}

Result<Biquad> ButterworthLowPass2(double cutoff_hz, double fs_hz) {
  if (!(fs_hz > 0) || !(cutoff_hz > 0) || !(cutoff_hz < fs_hz / 2))
    return Status::InvalidArgument("Butterworth cut-off " + std::to_string(cutoff_hz) +
                                   " Hz must lie between 0 and half the frame rate (" + std::to_string(fs_hz / 2) +
                                   " Hz)");
  // Analog prototype H(s) = Ωc² / (s² + √2 Ωc s + Ωc²) with Ωc = 2 fs tan(π fc / fs)
  // (prewarped), s = 2 fs (1 − z⁻¹)/(1 + z⁻¹); K = Ωc / (2 fs).
  const double K = std::tan(M_PI * cutoff_hz / fs_hz);
  const double norm = 1.0 / (1.0 + M_SQRT2 * K + K * K);
  Biquad f;
  f.b0 = K * K * norm;
  f.b1 = 2 * f.b0;
  f.b2 = f.b0;
  f.a1 = 2 * (K * K - 1) * norm;
  f.a2 = (1 - M_SQRT2 * K + K * K) * norm;
  return f;
}

namespace {

// Transposed direct form II from state (z1, z2).
std::vector<double> Run(const Biquad& f, const std::vector<double>& x, double z1, double z2) {
  std::vector<double> y(x.size());
  for (size_t n = 0; n < x.size(); ++n) {
    const double yn = f.b0 * x[n] + z1;
    z1 = f.b1 * x[n] - f.a1 * yn + z2;
    z2 = f.b2 * x[n] - f.a2 * yn;
    y[n] = yn;
  }
  return y;
}

// Steady-state state for a unit constant input (SciPy's lfilter_zi).
void SteadyState(const Biquad& f, double* z1, double* z2) {
  const double gain = (f.b0 + f.b1 + f.b2) / (1 + f.a1 + f.a2);
  *z2 = f.b2 - f.a2 * gain;
  *z1 = f.b1 - f.a1 * gain + *z2;
}

}  // namespace

std::vector<double> FilterCausal(const Biquad& f, const std::vector<double>& x) {
  if (x.empty()) return x;
  double z1, z2;
  SteadyState(f, &z1, &z2);
  return Run(f, x, z1 * x[0], z2 * x[0]);
}

std::vector<double> FiltFilt(const Biquad& f, const std::vector<double>& x) {
  const int n = static_cast<int>(x.size());
  if (n < 2) return x;
  // The padding must outlast the filter's start-up transient: with poles of radius
  // r = sqrt(a2) it decays as r^k, so pad until it is below 1e-4. (SciPy's default of
  // 3·(order+1) = 9 samples is ~10 times too short for 5 Hz at 300 fps, and the
  // transient then tilts the first frames' joint angles by mrad, enough to turn the
  // simulated body's heading and bend its whole path.)
  const double r = std::sqrt(std::max(f.a2, 0.0));
  const int transient = r > 0 && r < 1 ? static_cast<int>(std::ceil(std::log(1e-4) / std::log(r))) : 9;
  const int pad = std::min(std::max(9, transient), n - 1);
  // Odd reflection about the end samples keeps value and slope continuous.
  std::vector<double> ext;
  ext.reserve(n + 2 * pad);
  for (int i = pad; i >= 1; --i) ext.push_back(2 * x[0] - x[i]);
  ext.insert(ext.end(), x.begin(), x.end());
  for (int i = 1; i <= pad; ++i) ext.push_back(2 * x[n - 1] - x[n - 1 - i]);
  double z1, z2;
  SteadyState(f, &z1, &z2);
  std::vector<double> y = Run(f, ext, z1 * ext.front(), z2 * ext.front());
  std::reverse(y.begin(), y.end());
  y = Run(f, y, z1 * y.front(), z2 * y.front());
  std::reverse(y.begin(), y.end());
  return std::vector<double>(y.begin() + pad, y.begin() + pad + n);
}

Result<Kinematics> FilterJointAngles(const Kinematics& k, const AngleFilterOptions& opt, SmoothingReport* report) {
  auto bq = ButterworthLowPass2(opt.cutoff_hz, k.fps);
  if (!bq.ok()) return bq.status();
  // The cut-off in cycles per sample (where the zero-phase response |H|² is ½).
  const double half_power = opt.cutoff_hz / k.fps;
  SmoothingReport local;
  Kinematics out = SmoothJointAngleRuns(
      k,
      [&](const std::vector<double>& series, int) {
        // A linear time-invariant filter's dof: the fraction of the band it passes.
        const double pass = std::min(1.0, 2 * half_power);
        return SeriesSmoothing{opt.zero_phase ? FiltFilt(*bq, series) : FilterCausal(*bq, series),
                               pass * static_cast<double>(series.size()), half_power};
      },
      report ? report : &local);
  const std::string method = "lowpass: Butterworth 2nd order " + std::to_string(opt.cutoff_hz) + " Hz, " +
                             (opt.zero_phase ? "zero phase (forward-backward)" : "causal");
  if (report) report->method = method;
  out.metadata["filter"] = method;
  return out;
}

}  // namespace wormdrag
