#include "core/io/frame_quality.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "core/io/kinematics.h"

namespace wormdrag {
namespace {

TEST(FrameQuality, RoundTripsThroughTheReader) {
  const std::vector<FrameQuality> rows = {
      {0, 0.0, "valid", 0.9123}, {1, 1 / 30.0, "touching", 0.0}, {2, 2 / 30.0, "coiled", 0.0}};
  auto back = ParseFrameQuality(FormatFrameQuality(rows), "q.csv");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ((*back)[i].frame, rows[i].frame);
    EXPECT_NEAR((*back)[i].t, rows[i].t, 1e-6);
    EXPECT_EQ((*back)[i].status, rows[i].status);
    EXPECT_NEAR((*back)[i].quality, rows[i].quality, 1e-4);
  }
}

TEST(FrameQuality, ErrorsNameTheLineAndColumn) {
  auto bad = ParseFrameQuality("frame,t,status,quality\n0,0,valid,1.5\n", "q.csv");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().ToString().find("q.csv:2: column 4 (quality)"), std::string::npos) << bad.status().ToString();
  auto header = ParseFrameQuality("t,x0,y0\n", "k.csv");
  ASSERT_FALSE(header.ok());
  EXPECT_NE(header.status().ToString().find("header"), std::string::npos);
}

TEST(FrameQuality, SideFileBesideTheKinematicsLeavesThemReadable) {
  EXPECT_EQ(QualityPathFor("dir/k.csv"), "dir/k.quality.csv");
  EXPECT_EQ(QualityPathFor("k.txt"), "k.txt.quality.csv");
  // The kinematics file itself keeps its binding format (docs/conventions.md §6).
  const std::string dir = testing::TempDir();
  Kinematics k;
  k.fps = 30;
  k.metadata["fps"] = "30";
  Frame f;
  f.valid = true;
  for (int j = 0; j < kNumPoints; ++j) f.p[j] = Vec2(0.1 * j, 0);
  f.arc_length = 1.3;
  k.frames = {f, f};
  k.frames[1].t = 1 / 30.0;
  const std::string path = dir + "/quality_k.csv";
  ASSERT_TRUE(WriteKinematics(k, path).ok());
  ASSERT_TRUE(WriteFrameQuality({{0, 0, "valid", 0.9}, {1, 1 / 30.0, "valid", 0.8}}, QualityPathFor(path)).ok());
  auto kin = ReadKinematics(path);
  ASSERT_TRUE(kin.ok()) << kin.status().ToString();
  EXPECT_EQ(kin->frames.size(), 2u);
  auto q = ReadFrameQuality(QualityPathFor(path));
  ASSERT_TRUE(q.ok()) << q.status().ToString();
  EXPECT_EQ(q->size(), 2u);
  std::filesystem::remove(path);
  std::filesystem::remove(QualityPathFor(path));
}

}  // namespace
}  // namespace wormdrag
