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

TEST(FrameQuality, FramesBelowTheMinimumBecomeMissing) {
  const std::string text =
      "# fps: 10\n# source: test\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n0.1,0,0,1,0.1,2,0\n0.2,nan,nan,nan,nan,nan,nan\n"
      "0.3,0,0,1,0.2,2,0\n";
  const std::vector<FrameQuality> q = {
      {0, 0.0, "valid", 0.9}, {1, 0.1, "valid", 0.5}, {2, 0.2, "coiled", 0.0}, {3, 0.3, "valid", 0.7}};
  int masked = -1;
  auto out = MaskLowQualityFrames(text, "k.csv", q, "k.quality.csv", 0.7, &masked);
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  // Frame 1 is masked; frame 2 was missing already; frame 3 is at the minimum and stays.
  EXPECT_EQ(masked, 1);
  EXPECT_EQ(*out,
            "# fps: 10\n# source: test\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n0.1,nan,nan,nan,nan,nan,nan\n"
            "0.2,nan,nan,nan,nan,nan,nan\n0.3,0,0,1,0.2,2,0\n");
  auto k = ParseKinematics(*out, "k.csv");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  EXPECT_TRUE(k->frames[0].valid);
  EXPECT_FALSE(k->frames[1].valid);
  EXPECT_TRUE(k->frames[3].valid);
  // Nothing below 0: the text comes back as written.
  auto all = MaskLowQualityFrames(text, "k.csv", q, "k.quality.csv", 0, &masked);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(*all, text);
  EXPECT_EQ(masked, 0);
}

TEST(FrameQuality, AQualityFileOfAnotherRecordingIsRefused) {
  const std::string text = "# fps: 10\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n0.1,0,0,1,0.1,2,0\n";
  auto shorter = MaskLowQualityFrames(text, "k.csv", {{0, 0.0, "valid", 0.9}}, "q.csv", 0.5);
  ASSERT_FALSE(shorter.ok());
  EXPECT_NE(shorter.status().ToString().find("k.csv:4: more frames than the 1 rows of q.csv"), std::string::npos)
      << shorter.status().ToString();
  auto shifted = MaskLowQualityFrames(text, "k.csv", {{0, 0.0, "valid", 0.9}, {1, 0.2, "valid", 0.9}}, "q.csv", 0.5);
  ASSERT_FALSE(shifted.ok());
  EXPECT_NE(shifted.status().ToString().find("k.csv:4: t = 0.1 s"), std::string::npos) << shifted.status().ToString();
  auto longer = MaskLowQualityFrames(
      text, "k.csv", {{0, 0.0, "valid", 0.9}, {1, 0.1, "valid", 0.9}, {2, 0.2, "valid", 0.9}}, "q.csv", 0.5);
  ASSERT_FALSE(longer.ok());
  EXPECT_NE(longer.status().ToString().find("2 frames, but q.csv has 3 rows"), std::string::npos);
  EXPECT_FALSE(MaskLowQualityFrames(text, "k.csv", {}, "q.csv", 1.5).ok());
}

}  // namespace
}  // namespace wormdrag
