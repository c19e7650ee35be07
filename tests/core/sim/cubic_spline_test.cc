#include "core/sim/cubic_spline.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(CubicSpline, ReproducesCubicsExactly) {
  // Not-a-knot splines reproduce any cubic, on non-uniform knots too.
  std::vector<double> x = {0, 0.3, 0.5, 1.1, 1.2, 2.0}, y;
  auto f = [](double t) { return 1 - 2 * t + 0.5 * t * t - 0.7 * t * t * t; };
  auto df = [](double t) { return -2 + t - 2.1 * t * t; };
  for (double t : x) y.push_back(f(t));
  CubicSpline s(x, y);
  for (double t = 0; t <= 2.0; t += 0.037) {
    EXPECT_NEAR(s.Value(t), f(t), 1e-12) << t;
    EXPECT_NEAR(s.Derivative(t), df(t), 1e-11) << t;
  }
}

TEST(CubicSpline, FourthOrderOnSmoothData) {
  auto err = [](int n) {
    std::vector<double> x, y;
    for (int i = 0; i <= n; ++i) {
      x.push_back(i * 3.0 / n);
      y.push_back(std::sin(x.back()));
    }
    CubicSpline s(x, y);
    double e = 0;
    for (double t = 0; t <= 3.0; t += 0.001) e = std::max(e, std::abs(s.Value(t) - std::sin(t)));
    return e;
  };
  const double order = std::log2(err(20) / err(40));
  EXPECT_GT(order, 3.5);
  EXPECT_LT(order, 4.7);
}

TEST(CubicSpline, FewPoints) {
  CubicSpline one({1.0}, {2.0});
  EXPECT_EQ(one.Value(5), 2.0);
  CubicSpline two({0.0, 1.0}, {0.0, 2.0});
  EXPECT_DOUBLE_EQ(two.Value(0.25), 0.5);
  EXPECT_DOUBLE_EQ(two.Derivative(0.25), 2.0);
  CubicSpline three({0.0, 1.0, 3.0}, {0.0, 1.0, 9.0});  // y = t²
  EXPECT_NEAR(three.Value(2.0), 4.0, 1e-12);
  EXPECT_NEAR(three.Derivative(2.0), 4.0, 1e-12);
}

}  // namespace
}  // namespace wormdrag
