// A discrete smoothing spline for equally spaced samples (Whittaker–Henderson):
//
//   z = argmin ‖y − z‖² + λ ‖D_d z‖²,   D_d = d-th order differences,
//
// the sampled counterpart of the natural smoothing spline of degree 2d − 1 (d = 2:
// cubic, d = 3: quintic, as in Woltring's GCVSPL). Its frequency response away from
// the ends is 1 / (1 + λ (2 sin(ω/2))^{2d}): flat in the pass band, so a gait's
// harmonics pass with little loss while white tracking noise above them is removed.
//
// λ is chosen by generalized cross-validation (Craven & Wahba 1979):
//   GCV(λ) = n · RSS(λ) / (n − tr H(λ))²,   H = (I + λ DᵀD)⁻¹,
// and the noise variance is then estimated as RSS / (n − tr H). The system is banded
// (half-bandwidth d) and solved as the least-squares problem it is, by Givens rotations
// of [√λ D; I], not through I + λ DᵀD, whose condition (λ 4^d) exceeds 1/ε at a gait's λ
// for orders above 3. A solve and the exact trace (Hutchinson & de Hoog's recursion for
// the band of H) cost O(n d²).
#pragma once

#include <vector>

#include "core/common/status.h"

namespace wormdrag {

// The highest order accepted: λ grows as (fps / cut-off)^{2d}, and beyond 6 it leaves
// the λ search range at tracking frame rates.
inline constexpr int kMaxSplineOrder = 6;

struct SmoothingSplineOptions {
  // Order d of the penalised differences. Default: 3 (quintic), which keeps the
  // harmonics of the gait that a cubic spline (d = 2) attenuates at the same noise
  // removal; docs/estimation.md shows the comparison.
  int order = 3;
  // GCV searches log10 λ on [min_log10_lambda, max_log10_lambda] (λ in sample units),
  // first on a grid of `grid_step`, then by golden section around the best grid point.
  // Default: −6 … 14, which spans "interpolate" to "a polynomial of degree d − 1"
  // for recordings of up to ~10⁴ frames.
  double min_log10_lambda = -6;
  double max_log10_lambda = 14;
  double grid_step = 0.25;
  // GCV minimises the squared error of the samples, which tolerates a small loss of
  // amplitude at the dominant frequency; a body's speed goes with the amplitude
  // squared, so that loss becomes a path error that grows with the distance travelled
  // and biases the fit (toward the anisotropy that makes up the speed). λ is therefore
  // capped so that the dominant frequency (the periodogram's peak) loses at most this
  // share of its amplitude. Default: 1e-3 (a 0.2 % speed error). 0 = GCV alone.
  double max_fundamental_loss = 1e-3;
  // The λ of each shape series is this multiple of the chosen one (after the cap).
  // Default: 1, as chosen. The estimate's smoothing check (core/estimate/bootstrap.h)
  // refits the data smoothed with 0.1 and 10: choices GCV cannot tell from its own.
  double lambda_scale = 1;
  Status Validate() const;
};

struct SmoothedSeries {
  std::vector<double> z;  // the smoothed samples
  double lambda = 0;      // the chosen λ (sample units)
  double dof = 0;         // tr H: the effective number of parameters
  double rss = 0;         // Σ (y − z)²
  double gcv = 0;         // the GCV score at λ
  double noise_sd = 0;    // sqrt(RSS / (n − tr H)): the estimated noise per sample
  double dominant = 0;    // the dominant frequency, cycles per sample (0 if not looked for)
  bool capped = false;    // λ was lowered below GCV's choice to keep the dominant frequency
  // The frequency (cycles per sample) at which the response falls to ½.
  double HalfPowerFrequency() const;
  int order = 3;
};

// Smooths with a given λ ≥ 0 (λ = 0 returns y). Needs n > order samples (shorter
// series are returned unchanged with dof = n).
SmoothedSeries SmoothWithLambda(const std::vector<double>& y, double lambda, int order);

// The frequency (cycles per sample) with the most power in the mean-removed series,
// searched between one cycle per series and a quarter of the sampling rate.
double DominantFrequency(const std::vector<double>& y);

// Smooths with λ chosen by GCV (capped as the options say). Non-finite samples are refused.
Result<SmoothedSeries> SmoothByGcv(const std::vector<double>& y, const SmoothingSplineOptions& opt = {});

}  // namespace wormdrag
