#include "core/filter/smoothing_spline.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

namespace wormdrag {
namespace {

// Coefficients of the d-th difference: c_k = (−1)^{d−k} C(d, k), k = 0 … d.
std::vector<double> DifferenceStencil(int d) {
  std::vector<double> c(d + 1);
  double binom = 1;
  for (int k = 0; k <= d; ++k) {
    c[k] = ((d - k) % 2 ? -1.0 : 1.0) * binom;
    binom = binom * (d - k) / (k + 1);
  }
  return c;
}

// The QR factorisation of B = [√λ D; I] (BᵀB = A) by Givens rotations, without forming A:
// A's condition grows as λ 4^d, which at a gait's λ and tracking frame rates exceeds
// 1/ε for orders above 3, while B's is its square root. Rows are absorbed in the order
// of their first column, so every row of R spans at most d + 1 columns and each new row
// meets at most d + 1 of them. r[k*(d+1)+m] = R(k, k+m); qty = the first n entries of Qᵀ[0; y].
struct BandedQr {
  int n = 0, d = 0;
  std::vector<double> r, qty;
};

BandedQr Factorise(const std::vector<double>& y, int d, double lambda) {
  const std::vector<double> c = DifferenceStencil(d);
  const int n = static_cast<int>(y.size()), w = d + 1;
  BandedQr f;
  f.n = n;
  f.d = d;
  f.r.assign(static_cast<size_t>(n) * w, 0.0);
  f.qty.assign(n, 0.0);
  std::vector<char> has(n, 0);
  std::vector<double> v(w);
  // Rotates the row v (columns k … k+d) with right-hand side rhs into R. Its first
  // nonzero column only moves right, so `first` tracks it instead of shifting v.
  auto absorb = [&](int k, double rhs) {
    int first = 0;  // v[first] is the entry of column k
    for (; k < n && first < w; ++k, ++first) {
      double* R = &f.r[static_cast<size_t>(k) * w];
      if (!has[k]) {
        for (int m = 0; m < w; ++m) R[m] = first + m < w ? v[first + m] : 0.0;
        f.qty[k] = rhs;
        has[k] = 1;
        return;
      }
      const double x = v[first];
      if (x == 0) continue;
      const double rho = std::sqrt(R[0] * R[0] + x * x), cs = R[0] / rho, sn = x / rho;
      R[0] = rho;
      for (int m = 1; first + m < w; ++m) {
        const double p = R[m], q = v[first + m];
        R[m] = cs * p + sn * q;
        v[first + m] = cs * q - sn * p;
      }
      const double p = f.qty[k];
      f.qty[k] = cs * p + sn * rhs;
      rhs = cs * rhs - sn * p;
    }
  };
  const double root = std::sqrt(lambda);
  for (int j = 0; j < n; ++j) {
    if (j < n - d) {
      for (int m = 0; m < w; ++m) v[m] = root * c[m];
      absorb(j, 0.0);
    }
    std::fill(v.begin(), v.end(), 0.0);
    v[0] = 1;
    absorb(j, y[j]);
  }
  return f;
}

// R z = Qᵀy by back substitution.
std::vector<double> Solve(const BandedQr& f) {
  const int n = f.n, w = f.d + 1;
  std::vector<double> z(n);
  for (int i = n - 1; i >= 0; --i) {
    double s = f.qty[i];
    for (int m = 1; m < w && i + m < n; ++m) s -= f.r[static_cast<size_t>(i) * w + m] * z[i + m];
    z[i] = s / f.r[static_cast<size_t>(i) * w];
  }
  return z;
}

// tr A⁻¹ from the band of Σ = A⁻¹ (Hutchinson & de Hoog 1985), with A = RᵀR written
// as L·diag(D)·Lᵀ, L = Rᵀ diag(R)⁻¹ and D = diag(R)²: for i = n−1 … 0,
//   Σ(i, j) = −Σ_k L(k, i) Σ(k, j)   (i < j ≤ i + d),
//   Σ(i, i) = 1 / D_i − Σ_k L(k, i) Σ(k, i),   k = i+1 … i+d.
double TraceOfInverse(const BandedQr& f) {
  const int n = f.n, d = f.d, w = d + 1;
  std::vector<double> s(static_cast<size_t>(n) * w, 0.0);  // s[i*w+m] = Σ(i, i+m)
  auto S = [&](int i, int j) -> double {                   // symmetric access within the band
    if (i > j) std::swap(i, j);
    return s[static_cast<size_t>(i) * w + (j - i)];
  };
  std::vector<double> l(w);  // l[m] = L(i + m, i), the column of L below row i
  double trace = 0;
  for (int i = n - 1; i >= 0; --i) {
    const int last = std::min(n - 1, i + d);
    const double* R = &f.r[static_cast<size_t>(i) * w];
    for (int m = 1; i + m <= last; ++m) l[m] = R[m] / R[0];
    for (int j = last; j > i; --j) {
      double v = 0;
      for (int k = i + 1; k <= last; ++k) v -= l[k - i] * S(k, j);
      s[static_cast<size_t>(i) * w + (j - i)] = v;
    }
    double v = 1.0 / (R[0] * R[0]);
    for (int k = i + 1; k <= last; ++k) v -= l[k - i] * S(k, i);
    s[static_cast<size_t>(i) * w] = v;
    trace += v;
  }
  return trace;
}

}  // namespace

Status SmoothingSplineOptions::Validate() const {
  if (order < 1 || order > kMaxSplineOrder)
    return Status::InvalidArgument("smoothing spline order must be 1 … " + std::to_string(kMaxSplineOrder));
  if (!(max_fundamental_loss >= 0 && max_fundamental_loss < 1))
    return Status::InvalidArgument("smoothing spline: max_fundamental_loss must lie in [0, 1)");
  if (!(min_log10_lambda < max_log10_lambda) || !(grid_step > 0))
    return Status::InvalidArgument("smoothing spline: empty λ search range");
  if (!(lambda_scale > 0 && lambda_scale < 1e6))
    return Status::InvalidArgument("smoothing spline: lambda_scale must lie in (0, 1e6)");
  return Status::Ok();
}

double SmoothedSeries::HalfPowerFrequency() const {
  if (!(lambda > 0)) return 0.5;
  const double x = std::pow(lambda, -1.0 / (2 * order)) / 2;
  return x >= 1 ? 0.5 : std::asin(x) / M_PI;
}

SmoothedSeries SmoothWithLambda(const std::vector<double>& y, double lambda, int order) {
  SmoothedSeries s;
  s.order = order;
  s.lambda = lambda;
  const int n = static_cast<int>(y.size());
  if (n <= order || !(lambda > 0)) {
    s.z = y;
    s.dof = n;
    return s;
  }
  const BandedQr f = Factorise(y, order, lambda);
  s.z = Solve(f);
  s.dof = TraceOfInverse(f);
  for (int i = 0; i < n; ++i) s.rss += (y[i] - s.z[i]) * (y[i] - s.z[i]);
  const double free = n - s.dof;
  s.gcv = free > 0 ? n * s.rss / (free * free) : HUGE_VAL;
  s.noise_sd = free > 0 ? std::sqrt(s.rss / free) : 0;
  return s;
}

double DominantFrequency(const std::vector<double>& y) {
  const int n = static_cast<int>(y.size());
  if (n < 8) return 0;
  double mean = 0;
  for (double v : y) mean += v;
  mean /= n;
  // A grid of half the periodogram's resolution, from one cycle per series up; the
  // phasor e^{iωk} advances by one complex product per sample.
  const double step = 0.5 / n;
  double best_f = 0, best_p = -1;
  for (double f = 1.0 / n; f <= 0.25; f += step) {
    const std::complex<double> rot = std::polar(1.0, 2 * M_PI * f);
    std::complex<double> phasor = 1, sum = 0;
    for (int i = 0; i < n; ++i) {
      sum += (y[i] - mean) * phasor;
      phasor *= rot;
    }
    const double p = std::norm(sum);
    if (p > best_p) best_p = p, best_f = f;
  }
  return best_f;
}

Result<SmoothedSeries> SmoothByGcv(const std::vector<double>& y, const SmoothingSplineOptions& opt) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  for (size_t i = 0; i < y.size(); ++i)
    if (!std::isfinite(y[i]))
      return Status::InvalidArgument("smoothing: sample " + std::to_string(i) + " is not finite");
  const int n = static_cast<int>(y.size());
  if (n <= opt.order + 2) return SmoothWithLambda(y, 0, opt.order);
  // Centre and scale so that λ's range is independent of the signal's units; the
  // smoother is linear and reproduces constants, so this changes nothing else.
  double mean = 0;
  for (double v : y) mean += v;
  mean /= n;
  std::vector<double> yc(n);
  for (int i = 0; i < n; ++i) yc[i] = y[i] - mean;

  auto score = [&](double log_lambda) { return SmoothWithLambda(yc, std::pow(10.0, log_lambda), opt.order).gcv; };
  double best_log = opt.min_log10_lambda, best = HUGE_VAL;
  for (double g = opt.min_log10_lambda; g <= opt.max_log10_lambda + 1e-9; g += opt.grid_step) {
    const double v = score(g);
    if (v < best) best = v, best_log = g;
  }
  // Golden section within one grid step on either side of the best grid point.
  double a = std::max(opt.min_log10_lambda, best_log - opt.grid_step);
  double b = std::min(opt.max_log10_lambda, best_log + opt.grid_step);
  const double r = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = b - r * (b - a), x2 = a + r * (b - a), f1 = score(x1), f2 = score(x2);
  for (int it = 0; it < 30 && b - a > 1e-4; ++it) {
    if (f1 < f2) {
      b = x2, x2 = x1, f2 = f1, x1 = b - r * (b - a), f1 = score(x1);
    } else {
      a = x1, x1 = x2, f1 = f2, x2 = a + r * (b - a), f2 = score(x2);
    }
  }
  const double chosen = f1 < f2 ? x1 : x2;
  double lambda = std::pow(10.0, std::min(f1, f2) < best ? chosen : best_log);
  double dominant = 0;
  bool capped = false;
  if (opt.max_fundamental_loss > 0) {
    dominant = DominantFrequency(SmoothWithLambda(yc, lambda, opt.order).z);
    // Gain 1 / (1 + λ (2 sin(π f))^{2d}) ≥ 1 − loss  ⇔  λ ≤ loss / (1 − loss) / (2 sin(π f))^{2d}.
    const double w = std::pow(2 * std::sin(M_PI * dominant), 2 * opt.order);
    const double cap = w > 0 ? opt.max_fundamental_loss / (1 - opt.max_fundamental_loss) / w : HUGE_VAL;
    if (lambda > cap) lambda = cap, capped = true;
  }
  SmoothedSeries s = SmoothWithLambda(yc, lambda, opt.order);
  s.dominant = dominant;
  s.capped = capped;
  for (double& v : s.z) v += mean;
  return s;
}

}  // namespace wormdrag
