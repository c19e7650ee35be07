#include "core/io/gaps.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(Gaps, InterpolatesShapeAndPoseLinearly) {
  Kinematics k;
  k.fps = 10;
  Shape qa{}, qb{};
  for (int j = 0; j < kNumJoints; ++j) {
    qa[j] = 0.1;
    qb[j] = -0.1;
  }
  const double l = 0.1;
  k.frames.resize(6);
  for (int i = 0; i < 6; ++i) k.frames[i].t = i / 10.0;
  k.frames[0].valid = k.frames[4].valid = true;
  k.frames[0].p = LabPoints({0, 0, 0}, qa, l);
  k.frames[4].p = LabPoints({1, 0, 0.4}, qb, l);
  EXPECT_EQ(InterpolateShortGaps(k, 2), 0);  // the gap is 3 frames
  EXPECT_EQ(InterpolateShortGaps(k, 3), 3);
  EXPECT_FALSE(k.frames[5].valid);  // no valid frame after it
  const Shape mid = ShapeOf(k.frames[2].p);
  for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR(mid[j], 0.0, 1e-9);
  for (int m = 0; m < kNumLinks; ++m) EXPECT_NEAR((k.frames[2].p[m + 1] - k.frames[2].p[m]).norm(), l, 1e-9);
  EXPECT_EQ(k.metadata["interpolated_frames"], "3");
}

}  // namespace
}  // namespace wormdrag
