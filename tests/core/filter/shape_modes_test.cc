#include "core/filter/shape_modes.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/model/body.h"

namespace wormdrag {
namespace {

// A travelling wave (two shape modes) with a harmonic (two more), 5 s at 300 fps,
// Gaussian noise of σ mm on every point.
Kinematics Wave(double sigma, unsigned seed) {
  Kinematics k;
  k.fps = 300;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, sigma);
  for (int f = 0; f < 1500; ++f) {
    const double t = f / k.fps;
    Shape q;
    for (int i = 0; i < kNumJoints; ++i)
      q[i] = 0.5 * std::sin(2 * M_PI * 2 * t - 0.6 * (i + 1)) + 0.06 * std::sin(2 * M_PI * 6 * t - 1.8 * (i + 1));
    Frame fr;
    fr.t = t;
    fr.valid = true;
    fr.p = LabPoints({0.2 * t, 0, 0}, q, 1.0 / kNumLinks);
    for (Vec2& p : fr.p) p += Vec2(g(rng), g(rng));
    k.frames.push_back(fr);
  }
  return k;
}

TEST(ShapeModes, SeparateTheGaitFromWhiteUnitNoise) {
  auto m = NoiseWhitenedModes(Wave(0.005, 3));
  ASSERT_TRUE(m.ok()) << m.status().ToString();
  const int J = kNumJoints;
  // Exactly invertible.
  EXPECT_LT((m->from_modes * m->to_modes - Eigen::MatrixXd::Identity(J, J)).cwiseAbs().maxCoeff(), 1e-9);
  // Two modes carry the main wave, far above the noise; the harmonic is spatially
  // rough (1.8 rad per joint), where the noise is strongest, so its two modes stand
  // only a little above it; the other eight carry noise of unit variance.
  for (int j = 0; j < J - 4; ++j) {
    EXPECT_GT(m->snr[j], 0.7) << j;
    EXPECT_LT(m->snr[j], 1.3) << j;
  }
  for (int j = J - 4; j < J - 2; ++j) EXPECT_GT(m->snr[j], 1.3) << j;
  for (int j = J - 2; j < J; ++j) EXPECT_GT(m->snr[j], 100) << j;
}

TEST(ShapeModes, NeedEnoughConsecutiveFrames) {
  Kinematics k = Wave(0.005, 4);
  for (size_t f = 0; f < k.frames.size(); ++f) k.frames[f].valid = f % 3 == 0;
  EXPECT_FALSE(NoiseWhitenedModes(k).ok());
}

}  // namespace
}  // namespace wormdrag
