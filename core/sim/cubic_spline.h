// Not-a-knot cubic spline through (x_i, y_i), evaluated with its first derivative.
// Joint angles between frames come from it (docs/conventions.md §2: "a cubic spline, or better").
#pragma once

#include <cstddef>
#include <vector>

namespace wormdrag {

class CubicSpline {
 public:
  CubicSpline() = default;
  // x strictly increasing, x.size() == y.size() >= 1. With 1 point the spline is
  // constant, with 2 linear, with 3 the parabola through them (not-a-knot limit).
  CubicSpline(std::vector<double> x, std::vector<double> y);
  double Value(double t) const;
  double Derivative(double t) const;
  // Value and derivative at once (one interval search).
  void Evaluate(double t, double* value, double* derivative) const;

 private:
  size_t Interval(double t) const;
  std::vector<double> x_, y_, m_;  // m_: second derivatives at the knots
};

}  // namespace wormdrag
