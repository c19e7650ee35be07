#include "core/sim/cubic_spline.h"

#include <algorithm>

namespace wormdrag {

CubicSpline::CubicSpline(std::vector<double> x, std::vector<double> y)
    : x_(std::move(x)), y_(std::move(y)), m_(x_.size(), 0.0) {
  const size_t n = x_.size();
  if (n < 3) return;  // constant or linear: m = 0
  if (n == 3) {
    // The parabola through three points has constant second derivative.
    const double d0 = (y_[1] - y_[0]) / (x_[1] - x_[0]);
    const double d1 = (y_[2] - y_[1]) / (x_[2] - x_[1]);
    const double m = 2.0 * (d1 - d0) / (x_[2] - x_[0]);
    std::fill(m_.begin(), m_.end(), m);
    return;
  }
  // Tridiagonal system for the second derivatives with not-a-knot ends (the third
  // derivative is continuous at x_1 and x_{n-2}), reduced to n-2 unknowns m_1..m_{n-2}.
  std::vector<double> h(n - 1), d(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) {
    h[i] = x_[i + 1] - x_[i];
    d[i] = (y_[i + 1] - y_[i]) / h[i];
  }
  const size_t k = n - 2;
  std::vector<double> a(k), b(k), c(k), r(k);
  for (size_t j = 0; j < k; ++j) {
    const size_t i = j + 1;
    a[j] = h[i - 1];
    b[j] = 2.0 * (h[i - 1] + h[i]);
    c[j] = h[i];
    r[j] = 6.0 * (d[i] - d[i - 1]);
  }
  // m_0 = ((h0+h1) m_1 − h0 m_2)/h1 ;  m_{n-1} = ((h_{n-2}+h_{n-3}) m_{n-2} − h_{n-2} m_{n-3})/h_{n-3}
  b[0] += a[0] * (h[0] + h[1]) / h[1];
  c[0] -= a[0] * h[0] / h[1];
  b[k - 1] += c[k - 1] * (h[n - 2] + h[n - 3]) / h[n - 3];
  a[k - 1] -= c[k - 1] * h[n - 2] / h[n - 3];
  // Thomas algorithm (diagonally dominant enough in practice for smooth data).
  for (size_t j = 1; j < k; ++j) {
    const double w = a[j] / b[j - 1];
    b[j] -= w * c[j - 1];
    r[j] -= w * r[j - 1];
  }
  std::vector<double> m(k);
  m[k - 1] = r[k - 1] / b[k - 1];
  for (size_t j = k - 1; j-- > 0;) m[j] = (r[j] - c[j] * m[j + 1]) / b[j];
  for (size_t j = 0; j < k; ++j) m_[j + 1] = m[j];
  m_[0] = ((h[0] + h[1]) * m_[1] - h[0] * m_[2]) / h[1];
  m_[n - 1] = ((h[n - 2] + h[n - 3]) * m_[n - 2] - h[n - 2] * m_[n - 3]) / h[n - 3];
}

size_t CubicSpline::Interval(double t) const {
  if (x_.size() < 2 || t <= x_.front()) return 0;
  if (t >= x_.back()) return x_.size() - 2;
  return static_cast<size_t>(std::upper_bound(x_.begin(), x_.end(), t) - x_.begin()) - 1;
}

void CubicSpline::Evaluate(double t, double* value, double* derivative) const {
  if (x_.empty()) {
    *value = 0;
    *derivative = 0;
    return;
  }
  if (x_.size() == 1) {
    *value = y_[0];
    *derivative = 0;
    return;
  }
  const size_t i = Interval(t);
  const double h = x_[i + 1] - x_[i];
  const double a = (x_[i + 1] - t) / h, b = (t - x_[i]) / h;
  *value = a * y_[i] + b * y_[i + 1] + ((a * a * a - a) * m_[i] + (b * b * b - b) * m_[i + 1]) * h * h / 6.0;
  *derivative = (y_[i + 1] - y_[i]) / h + ((1 - 3 * a * a) * m_[i] + (3 * b * b - 1) * m_[i + 1]) * h / 6.0;
}

double CubicSpline::Value(double t) const {
  double v, d;
  Evaluate(t, &v, &d);
  return v;
}

double CubicSpline::Derivative(double t) const {
  double v, d;
  Evaluate(t, &v, &d);
  return d;
}

}  // namespace wormdrag
