#include "core/common/stats.h"

#include <cmath>
#include <limits>

namespace wormdrag {
namespace {

// Continued fraction of I_x(a, b) (converges fast for x < (a + 1) / (a + b + 2)).
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300, kEps = 1e-15;
  const double qab = a + b, qap = a + 1, qam = a - 1;
  double c = 1, d = 1 - qab * x / qap;
  if (std::fabs(d) < kTiny) d = kTiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m <= 10000; ++m) {
    const int m2 = 2 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1 + aa / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1) < kEps) break;
  }
  return h;
}

}  // namespace

double RegularizedIncompleteBeta(double a, double b, double x) {
  if (!(a > 0) || !(b > 0) || !(x >= 0) || !(x <= 1)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0) return 0;
  if (x == 1) return 1;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double front = std::exp(log_front);
  if (x < (a + 1) / (a + b + 2)) return front * BetaContinuedFraction(a, b, x) / a;
  return 1 - front * BetaContinuedFraction(b, a, 1 - x) / b;
}

double StudentTCdf(double t, double df) {
  if (!(df > 0) || std::isnan(t)) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(t)) return t > 0 ? 1 : 0;
  // P(|T| > |t|) = I_{df/(df+t²)}(df/2, 1/2).
  const double x = df / (df + t * t);
  const double tail = 0.5 * RegularizedIncompleteBeta(0.5 * df, 0.5, x);
  return t > 0 ? 1 - tail : tail;
}

double StudentTQuantile(double p, double df) {
  if (!(p > 0) || !(p < 1) || !(df > 0)) return std::numeric_limits<double>::quiet_NaN();
  if (p < 0.5) return -StudentTQuantile(1 - p, df);
  double lo = 0, hi = 1;
  while (StudentTCdf(hi, df) < p && hi < 1e300) hi *= 2;
  for (int i = 0; i < 2000 && hi - lo > 1e-13 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (StudentTCdf(mid, df) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double PredictionBound(const std::vector<double>& x, double alpha) {
  const SampleSummary s = Summarize(x);
  if (s.n < 2) return std::numeric_limits<double>::infinity();
  return s.mean + StudentTQuantile(1 - alpha, s.n - 1) * s.sd * std::sqrt(1 + 1.0 / s.n);
}

double PredictionPValue(const std::vector<double>& x, double value) {
  const SampleSummary s = Summarize(x);
  if (s.n < 2 || !(s.sd > 0)) return std::numeric_limits<double>::quiet_NaN();
  return 1 - StudentTCdf((value - s.mean) / (s.sd * std::sqrt(1 + 1.0 / s.n)), s.n - 1);
}

SampleSummary Summarize(const std::vector<double>& x) {
  SampleSummary s;
  s.n = static_cast<int>(x.size());
  if (s.n == 0) return s;
  double sum = 0;
  for (double v : x) sum += v;
  s.mean = sum / s.n;
  if (s.n > 1) {
    double ss = 0;
    for (double v : x) ss += (v - s.mean) * (v - s.mean);
    s.sd = std::sqrt(ss / (s.n - 1));
  }
  return s;
}

Result<WelchResult> WelchTTest(const std::vector<double>& a, const std::vector<double>& b) {
  for (const auto* g : {&a, &b}) {
    if (g->size() < 2) return Status::InvalidArgument("the t-test needs at least 2 values in each group");
    for (double v : *g)
      if (!std::isfinite(v)) return Status::InvalidArgument("the t-test needs finite values");
  }
  WelchResult r;
  r.a = Summarize(a);
  r.b = Summarize(b);
  const double va = r.a.sd * r.a.sd / r.a.n, vb = r.b.sd * r.b.sd / r.b.n;
  const double se2 = va + vb;
  if (!(se2 > 0)) return Status::InvalidArgument("the t-test needs some spread: both groups are constant");
  r.t = (r.a.mean - r.b.mean) / std::sqrt(se2);
  r.df = se2 * se2 / (va * va / (r.a.n - 1) + vb * vb / (r.b.n - 1));
  r.p_two_sided = 2 * StudentTCdf(-std::fabs(r.t), r.df);
  return r;
}

}  // namespace wormdrag
