#include "core/filter/butterworth.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(Butterworth, MatchesScipyCoefficients) {
  // scipy.signal.butter(2, 5 / 15): b = [0.15505103, 0.31010205, 0.15505103],
  // a = [1, −0.62020410, 0.24040821].
  auto f = ButterworthLowPass2(5, 30);
  ASSERT_TRUE(f.ok());
  EXPECT_NEAR(f->b0, 0.15505103, 1e-8);
  EXPECT_NEAR(f->b1, 0.31010205, 1e-8);
  EXPECT_NEAR(f->b2, 0.15505103, 1e-8);
  EXPECT_NEAR(f->a1, -0.62020410, 1e-8);
  EXPECT_NEAR(f->a2, 0.24040821, 1e-8);
}

TEST(Butterworth, FrequencyResponse) {
  for (double fs : {30.03003, 66.0, 300.0}) {
    auto f = ButterworthLowPass2(5, fs);
    ASSERT_TRUE(f.ok());
    EXPECT_NEAR(std::abs(f->Response(0, fs)), 1.0, 1e-12);                      // DC
    EXPECT_NEAR(20 * std::log10(std::abs(f->Response(5, fs))), -3.0103, 1e-3);  // cut-off
    // At 2 fc the prewarped digital filter equals the analog one at the warped frequency.
    const double r = std::tan(M_PI * 10 / fs) / std::tan(M_PI * 5 / fs);
    EXPECT_NEAR(std::abs(f->Response(10, fs)), 1 / std::sqrt(1 + std::pow(r, 4)), 1e-12);
    EXPECT_LT(std::abs(f->Response(10, fs)), 0.25);  // ≥ 12 dB down (analog: 12.3 dB)
  }
  EXPECT_FALSE(ButterworthLowPass2(20, 30).ok());
  EXPECT_FALSE(ButterworthLowPass2(0, 30).ok());
}

TEST(FiltFilt, ZeroPhaseOnASine) {
  const double fs = 100, f0 = 2;
  std::vector<double> x(400);
  for (size_t i = 0; i < x.size(); ++i) x[i] = std::sin(2 * M_PI * f0 * i / fs);
  auto f = ButterworthLowPass2(5, fs);
  const std::vector<double> y = FiltFilt(*f, x);
  const double gain = std::norm(f->Response(f0, fs));  // |H|²
  // Away from the ends: y = |H|² x exactly in phase.
  for (size_t i = 100; i < 300; ++i) EXPECT_NEAR(y[i], gain * x[i], 2e-3) << i;
  // The causal filter lags: its output at a zero crossing of x is clearly non-zero.
  const std::vector<double> c = FilterCausal(*f, x);
  EXPECT_GT(std::abs(c[200]), 0.2);  // x[200] = 0
}

TEST(FiltFilt, ConstantAndLineAreKept) {
  auto f = ButterworthLowPass2(5, 30);
  std::vector<double> x(50), line(50);
  for (int i = 0; i < 50; ++i) {
    x[i] = 0.7;
    line[i] = 0.1 * i - 2;
  }
  for (double v : FiltFilt(*f, x)) EXPECT_NEAR(v, 0.7, 1e-12);
  for (double v : FilterCausal(*f, x)) EXPECT_NEAR(v, 0.7, 1e-12);
  // Odd reflection keeps a straight line straight up to the ends (a small start-up
  // transient remains, as in SciPy: the initial state is that of a constant).
  const auto y = FiltFilt(*f, line);
  for (int i = 0; i < 50; ++i) EXPECT_NEAR(y[i], line[i], i < 10 || i >= 40 ? 1e-3 : 1e-6) << i;
  EXPECT_EQ(FiltFilt(*f, {1.0}).size(), 1u);
}

Kinematics Wave(int n, double fps, double ripple, double ripple_hz) {
  Kinematics k;
  k.fps = fps;
  k.frames.resize(n);
  for (int i = 0; i < n; ++i) {
    const double t = i / fps;
    Shape q;
    for (int j = 0; j < kNumJoints; ++j)
      q[j] = 0.5 * std::sin(5 * t - 0.6 * (j + 1)) + ripple * std::sin(2 * M_PI * ripple_hz * t + j);
    Pose g{1.0 + 0.1 * t, 2.0, 0.3 + 0.05 * t};
    k.frames[i].t = t;
    k.frames[i].valid = true;
    k.frames[i].p = LabPoints(g, q, 1.0 / kNumLinks);
    k.frames[i].arc_length = 1.0;
  }
  return k;
}

TEST(FilterJointAngles, RemovesHighFrequencyKeepsPoseAndMissing) {
  Kinematics k = Wave(120, 30, 0.05, 12.0);  // 12 Hz ripple on a 0.8 Hz wave
  k.frames[60].valid = false;
  auto out = FilterJointAngles(k, {});
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  EXPECT_FALSE(out->frames[60].valid);
  const Kinematics clean = Wave(120, 30, 0.0, 0.0);
  double err_before = 0, err_after = 0;
  int n = 0;
  for (int i = 10; i < 110; ++i) {
    if (i > 50 && i < 70) continue;  // near the gap each run has its own ends
    const Shape a = ShapeOf(clean.frames[i].p), b = ShapeOf(k.frames[i].p), c = ShapeOf(out->frames[i].p);
    for (int j = 0; j < kNumJoints; ++j) {
      err_before += std::abs(b[j] - a[j]);
      err_after += std::abs(c[j] - a[j]);
      ++n;
    }
    // Link length and centroid are kept (pose from each frame's best fit).
    EXPECT_NEAR((out->frames[i].p[1] - out->frames[i].p[0]).norm(), 1.0 / kNumLinks, 1e-9);
  }
  EXPECT_LT(err_after, 0.25 * err_before) << err_before / n << " " << err_after / n;
}

}  // namespace
}  // namespace wormdrag
