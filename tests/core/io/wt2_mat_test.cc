#include "core/io/wt2_mat.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "core/io/gaps.h"

namespace wormdrag {
namespace {

const std::string kMat = std::string(WORMDRAG_SHARED_DIR) + "/data/real/modes2movement/short_worm_features.mat";

TEST(Wt2Mat, ImportsModes2MovementWithGapsPreserved) {
  if (!std::filesystem::exists(kMat)) GTEST_SKIP() << kMat << " not found";
  auto r = ReadWt2Features(kMat);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  EXPECT_EQ(r->points_per_frame, 49);
  ASSERT_EQ(k.frames.size(), 706u);
  EXPECT_NEAR(k.fps, 30.03003, 1e-4);
  EXPECT_EQ(k.NumValid(), 400);
  // PROVENANCE.md: valid runs 0–13, 19–34, …, 398–498; 499–705 missing.
  for (int i : {0, 13, 19, 34, 398, 498}) EXPECT_TRUE(k.frames[i].valid) << i;
  for (int i : {14, 18, 35, 39, 397, 499, 705}) EXPECT_FALSE(k.frames[i].valid) << i;
  ASSERT_EQ(r->annotation.size(), 706u);
  EXPECT_EQ(r->annotation[14], 2);     // dropped frame
  EXPECT_EQ(r->annotation[499], 102);  // contour touches the boundary
  // µm → mm: a ~0.84 mm worm at plate coordinates ~20–24 mm.
  EXPECT_NEAR(k.BodyLength(), 0.84, 0.08);
  EXPECT_GT(k.frames[0].p[0].x(), 20.0);
  EXPECT_LT(k.frames[0].p[0].x(), 24.5);
  // Head first: the worm crawls forward, toward point 0.
  const Vec2 v = (k.frames[13].p[7] - k.frames[0].p[7]);
  EXPECT_GT(v.dot(k.frames[0].p[0] - k.frames[0].p[13]), 0);
}

TEST(Wt2Mat, InterpolatingShortGapsFillsOnlyThem) {
  if (!std::filesystem::exists(kMat)) GTEST_SKIP() << kMat << " not found";
  auto r = ReadWt2Features(kMat);
  ASSERT_TRUE(r.ok());
  Kinematics k = r->kinematics;
  const int filled = InterpolateShortGaps(k, 8);
  // 18 dropped-frame bursts of 5–8 frames between the valid runs of 0–498 (99 frames).
  EXPECT_EQ(filled, 99);
  for (int i = 0; i <= 498; ++i) EXPECT_TRUE(k.frames[i].valid) << i;
  EXPECT_FALSE(k.frames[499].valid);
}

// A 789-byte file whose compressed skeleton inflates to 50 million 1-byte integers
// (found by the fuzzer): refused before the 400 MB of doubles are allocated.
TEST(Wt2Mat, CompressedArrayBeyondTheElementBudgetIsRefused) {
  const std::string path = std::string(WORMDRAG_SOURCE_DIR) +
                           "/tests/fuzz/regressions/wt2_mat/compressed_int8_bomb.mat";
  auto r = ReadWt2Features(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), Status::Code::kInvalidArgument);
  EXPECT_NE(r.status().message().find("elements; at most 25000000"), std::string::npos) << r.status().message();
}

TEST(Wt2Mat, ErrorsNameTheFile) {
  auto r = ReadWt2Features("/nonexistent/x.mat");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("/nonexistent/x.mat"), std::string::npos);
}

}  // namespace
}  // namespace wormdrag
