#include "core/filter/smoothing_spline.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Dense>

namespace wormdrag {
namespace {

// The dense solution of (I + λ DᵀD) z = y, for checking the banded one.
Eigen::MatrixXd DenseSystem(int n, int d, double lambda) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Identity(n, n);
  for (int k = 0; k < d; ++k) {
    const int m = static_cast<int>(D.rows());
    D = (D.bottomRows(m - 1) - D.topRows(m - 1)).eval();
  }
  return Eigen::MatrixXd::Identity(n, n) + lambda * D.transpose() * D;
}

TEST(SmoothingSpline, BandedSolveAndTraceMatchDenseAlgebra) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int d : {1, 2, 3}) {
    for (double lambda : {0.1, 10.0, 1e4}) {
      const int n = 40;
      std::vector<double> y(n);
      Eigen::VectorXd yv(n);
      for (int i = 0; i < n; ++i) yv[i] = y[i] = g(rng);
      const Eigen::MatrixXd A = DenseSystem(n, d, lambda);
      const Eigen::MatrixXd H = A.inverse();
      const Eigen::VectorXd z = H * yv;
      const SmoothedSeries s = SmoothWithLambda(y, lambda, d);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(s.z[i], z[i], 1e-9) << "d " << d << " λ " << lambda;
      EXPECT_NEAR(s.dof, H.trace(), 1e-9 * n);
    }
  }
}

TEST(SmoothingSpline, ReproducesPolynomialsOfDegreeBelowTheOrder) {
  std::vector<double> y(50);
  for (size_t i = 0; i < y.size(); ++i) y[i] = 0.3 - 0.02 * i + 1e-3 * i * i;
  const SmoothedSeries s3 = SmoothWithLambda(y, 1e6, 3);  // quadratic: in the null space of D3
  for (size_t i = 0; i < y.size(); ++i) EXPECT_NEAR(s3.z[i], y[i], 1e-7);
  // As λ → ∞ only the null space (degree < 3) passes.
  EXPECT_GT(SmoothWithLambda(y, 1e2, 3).dof, SmoothWithLambda(y, 1e6, 3).dof);
  EXPECT_NEAR(SmoothWithLambda(y, 1e11, 3).dof, 3.0, 1e-2);
  const SmoothedSeries s2 = SmoothWithLambda(y, 1e6, 2);  // D2 does not annihilate i²
  double worst = 0;
  for (size_t i = 0; i < y.size(); ++i) worst = std::max(worst, std::abs(s2.z[i] - y[i]));
  EXPECT_GT(worst, 1e-2);
}

TEST(SmoothingSpline, InteriorResponseIsTheWhittakerTransferFunction) {
  // Away from the ends a sinusoid passes with gain 1 / (1 + λ (2 sin(ω/2))^{2d}).
  const int n = 2000, d = 3;
  const double omega = 2 * M_PI * 0.02, lambda = 3e3;
  std::vector<double> y(n);
  for (int i = 0; i < n; ++i) y[i] = std::sin(omega * i);
  const SmoothedSeries s = SmoothWithLambda(y, lambda, d);
  const double gain = 1 / (1 + lambda * std::pow(2 * std::sin(omega / 2), 2 * d));
  for (int i = 800; i < 1200; ++i) EXPECT_NEAR(s.z[i], gain * y[i], 1e-6);
  // The reported half-power frequency is where that gain is ½.
  const double f = s.HalfPowerFrequency();
  EXPECT_NEAR(lambda * std::pow(2 * std::sin(M_PI * f), 2 * d), 1.0, 1e-9);
}

// Every order the options accept stays exact at the λ that tracking asks for: a half-
// power of 4 Hz at 300 and 1000 fps, 5 s. I + λ DᵀD has a condition of about λ 4^d:
// solved through it, order 4 loses 1e-5 of the signal and order 6 all of it (300 fps),
// and order 3 loses 2e-5 (1000 fps).
TEST(SmoothingSpline, EveryAcceptedOrderIsExactAtTrackingRates) {
  for (const double fps : {300.0, 1000.0}) {
    const int n = static_cast<int>(5 * fps);
    const double half_power = 4 / fps, omega = 2 * M_PI * 2 / fps;
    std::vector<double> y(n);
    for (int i = 0; i < n; ++i) y[i] = std::sin(omega * i);
    for (int d = 1; d <= kMaxSplineOrder; ++d) {
      SmoothingSplineOptions o;
      o.order = d;
      ASSERT_TRUE(o.Validate().ok()) << "order " << d;
      const double lambda = std::pow(2 * std::sin(M_PI * half_power), -2 * d);
      const SmoothedSeries s = SmoothWithLambda(y, lambda, d);
      const double gain = 1 / (1 + lambda * std::pow(2 * std::sin(omega / 2), 2 * d));
      double worst = 0;
      for (int i = 2 * n / 5; i < 3 * n / 5; ++i) worst = std::max(worst, std::abs(s.z[i] - gain * y[i]));
      EXPECT_LT(worst, fps < 500 ? 1e-6 : 1e-5) << fps << " fps, order " << d << ", λ " << lambda;
    }
  }
  SmoothingSplineOptions o;
  o.order = kMaxSplineOrder + 1;
  EXPECT_FALSE(o.Validate().ok());
}

// A gait-like signal: 2 Hz with harmonics, 5 s at 300 fps.
std::vector<double> Gait(int n, double fps) {
  std::vector<double> y(n);
  for (int i = 0; i < n; ++i) {
    const double t = i / fps;
    y[i] = 0.5 * std::sin(2 * M_PI * 2 * t) + 0.12 * std::sin(2 * M_PI * 4 * t + 0.3) +
           0.05 * std::sin(2 * M_PI * 6 * t + 1.1) + 0.1;
  }
  return y;
}

TEST(SmoothingSpline, GcvEstimatesTheNoiseAndRemovesIt) {
  const int n = 1500;
  const std::vector<double> truth = Gait(n, 300);
  for (double sigma : {0.02, 0.1}) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g(0, sigma);
    std::vector<double> y = truth;
    for (double& v : y) v += g(rng);
    auto s = SmoothByGcv(y);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    EXPECT_NEAR(s->noise_sd, sigma, 0.1 * sigma);
    double err = 0;
    for (int i = 0; i < n; ++i) err += (s->z[i] - truth[i]) * (s->z[i] - truth[i]);
    err = std::sqrt(err / n);
    EXPECT_LT(err, sigma / 4) << "σ " << sigma;
    // The gait's 6 Hz harmonic (0.02 cycles/sample) lies inside the pass band.
    EXPECT_GT(s->HalfPowerFrequency() * 300, 6.0);
  }
}

TEST(SmoothingSpline, TheDominantFrequencyKeepsItsAmplitude) {
  // A slow gait in heavy noise: GCV alone would trade a percent of the fundamental's
  // amplitude for noise; the cap keeps the loss below 1e-3.
  const int n = 1500;
  std::mt19937 rng(9);
  std::normal_distribution<double> g(0, 0.15);
  std::vector<double> y(n);
  const double f0 = 0.8 / 300;
  for (int i = 0; i < n; ++i) y[i] = 0.5 * std::sin(2 * M_PI * f0 * i) + g(rng);
  EXPECT_NEAR(DominantFrequency(y), f0, 0.5 / n);
  SmoothingSplineOptions gcv_only;
  gcv_only.max_fundamental_loss = 0;
  auto plain = SmoothByGcv(y, gcv_only);
  auto capped = SmoothByGcv(y);
  ASSERT_TRUE(plain.ok() && capped.ok());
  auto gain = [&](const SmoothedSeries& s) {
    return 1 / (1 + s.lambda * std::pow(2 * std::sin(M_PI * f0), 2 * s.order));
  };
  EXPECT_LT(gain(*plain), 0.999);  // what the cap is for
  EXPECT_TRUE(capped->capped);
  EXPECT_GE(gain(*capped), 0.999 - 1e-9);
  EXPECT_GT(capped->HalfPowerFrequency(), plain->HalfPowerFrequency());
}

TEST(SmoothingSpline, CleanDataPassUnchanged) {
  const int n = 1500;
  std::vector<double> y = Gait(n, 300);
  for (double& v : y) v = std::round(v * 1e9) / 1e9;  // what a written file keeps
  auto s = SmoothByGcv(y);
  ASSERT_TRUE(s.ok());
  double worst = 0;
  for (int i = 0; i < n; ++i) worst = std::max(worst, std::abs(s->z[i] - y[i]));
  EXPECT_LT(worst, 1e-6);
}

TEST(SmoothingSpline, RefusesNonFiniteSamples) {
  std::vector<double> y(20, 1.0);
  y[7] = std::nan("");
  auto s = SmoothByGcv(y);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().ToString().find("sample 7"), std::string::npos);
}

}  // namespace
}  // namespace wormdrag
