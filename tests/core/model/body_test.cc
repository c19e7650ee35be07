#include "core/model/body.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/model/friction_law.h"

namespace wormdrag {
namespace {

Shape SomeShape() {
  Shape q;
  for (int i = 0; i < kNumJoints; ++i) q[i] = 0.4 * std::sin(1.3 * i + 0.2);
  return q;
}

TEST(Body, LinkNumberingAndPoints) {
  // p_0 is the head tip; link 1 points from head to tail along q0.
  const Pose g{1.0, 2.0, M_PI / 2};
  Shape straight{};
  const Points p = LabPoints(g, straight, 0.1);
  EXPECT_NEAR(p[0].x(), 1.0, 1e-15);
  EXPECT_NEAR(p[0].y(), 2.0, 1e-15);
  EXPECT_NEAR(p[kNumLinks].y(), 2.0 + 1.3, 1e-12);
  EXPECT_NEAR(p[7].y(), 2.7, 1e-12);  // joint 7
}

TEST(Body, ShapeRoundTrip) {
  const Shape q = SomeShape();
  const Points p = LabPoints({0.3, -0.1, 2.5}, q, 0.08);
  const Shape back = ShapeOf(p);
  for (int i = 0; i < kNumJoints; ++i) EXPECT_NEAR(back[i], q[i], 1e-12);
  EXPECT_NEAR(HeadLinkAngle(p), 2.5, 1e-12);
}

TEST(Body, BestFitPoseRecoversExactPose) {
  const Shape q = SomeShape();
  const Pose g{0.7, -1.2, -2.9};
  const Pose fit = BestFitPose(LabPoints(g, q, 0.1), q, 0.1);
  EXPECT_NEAR(fit.x, g.x, 1e-12);
  EXPECT_NEAR(fit.y, g.y, 1e-12);
  EXPECT_NEAR(WrapAngle(fit.q0 - g.q0), 0, 1e-12);
}

TEST(Body, BestFitPoseUsesAllPoints) {
  // Noise on the head link alone barely moves the fitted pose.
  const Shape q = SomeShape();
  const Pose g{0, 0, 0.5};
  Points p = LabPoints(g, q, 0.1);
  p[0] += Vec2(0.02, -0.02);
  const Pose fit = BestFitPose(p, q, 0.1);
  EXPECT_LT(std::abs(fit.q0 - g.q0), 0.01);
}

TEST(Body, ReversedSwapsHeadAndTail) {
  const Points p = LabPoints({0.3, -0.1, 2.5}, SomeShape(), 0.08);
  const Points r = Reversed(p);
  EXPECT_EQ(r[0], p[kNumLinks]);
  EXPECT_EQ(r[kNumLinks], p[0]);
  EXPECT_EQ(Reversed(r), p);
  // A straight body moved 1 mm along itself is 1 mm from where it was, point by point.
  const Points q = LabPoints({0, 0, 0}, Shape{}, 0.1);
  Points moved = q;
  for (Vec2& v : moved) v.x() -= 1.0;
  EXPECT_NEAR(MeanPointDistance(q, moved), 1.0, 1e-12);
  EXPECT_EQ(MeanPointDistanceFlipped(q, moved), MeanPointDistance(q, Reversed(moved)));
  EXPECT_EQ(MeanPointDistance(p, p), 0.0);
  EXPECT_GT(MeanPointDistanceFlipped(p, p), 0.1);
}

TEST(FrictionLaw, ParseCoefficients) {
  auto c = ParseCoefficients("0.5,0.2,0.003,0.001");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->mu_n, 0.5);
  EXPECT_EQ(c->eta_t, 0.001);
  EXPECT_FALSE(ParseCoefficients("0.5,0.2,0.003").ok());
  EXPECT_FALSE(ParseCoefficients("0.5,0.2,0.003,0.001,1").ok());
  EXPECT_FALSE(ParseCoefficients("0.5,abc,0.003,0.001").ok());
  const auto neg = ParseCoefficients("0.5,0.2,-0.003,0.001");
  ASSERT_FALSE(neg.ok());
  EXPECT_NE(neg.status().message().find("eta_n"), std::string::npos);
}

TEST(FrictionLaw, IdentifiableCombinations) {
  const Coefficients c{0.6, 0.2, 0.009, 0.003};
  EXPECT_DOUBLE_EQ(c.K_mu(), 3.0);
  EXPECT_DOUBLE_EQ(c.K_eta(), 3.0);
  EXPECT_NEAR(c.v_c(), 66.6666666667, 1e-8);
  EXPECT_DOUBLE_EQ(c.Scaled(5).K_mu(), c.K_mu());
}

TEST(FrictionLaw, SmoothSign) {
  EXPECT_NEAR(SmoothSign(1.0, 1e-4), 1.0, 1e-8);
  EXPECT_NEAR(SmoothSign(-1.0, 1e-4), -1.0, 1e-8);
  EXPECT_EQ(SmoothSign(0.0, 1e-4), 0.0);
  EXPECT_NEAR(SmoothSign(1e-4, 1e-4), 1 / std::sqrt(2.0), 1e-15);
}

}  // namespace
}  // namespace wormdrag
