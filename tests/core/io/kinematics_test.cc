#include "core/io/kinematics.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

std::string Header(int points) {
  std::string h = "t";
  for (int i = 0; i < points; ++i) h += ",x" + std::to_string(i) + ",y" + std::to_string(i);
  return h + "\n";
}

std::string Row(double t, int points, double dx = 0.1) {
  std::string r = std::to_string(t);
  for (int i = 0; i < points; ++i) r += "," + std::to_string(i * dx) + ",0";
  return r + "\n";
}

TEST(Kinematics, ReadsAndResamples) {
  const std::string text = "# fps: 10\n# environment: agar\n" + Header(4) + Row(0, 4) + Row(0.1, 4);
  auto k = ParseKinematics(text, "k.csv");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  EXPECT_EQ(k->fps, 10);
  EXPECT_EQ(k->metadata.at("environment"), "agar");
  ASSERT_EQ(k->frames.size(), 2u);
  EXPECT_NEAR(k->BodyLength(), 0.3, 1e-12);
  for (int i = 0; i < kNumPoints; ++i) EXPECT_NEAR(k->frames[0].p[i].x(), 0.3 * i / kNumLinks, 1e-12);
}

TEST(Kinematics, ResampleKeepsEqualSpacedPointsAndHandlesCurves) {
  std::vector<Vec2> pl;
  for (int i = 0; i < kNumPoints; ++i) pl.emplace_back(std::cos(0.1 * i), std::sin(0.1 * i));
  // Already 14 points equally spaced along the arc: unchanged.
  auto r = ResampleByArcLength(pl);
  ASSERT_TRUE(r.ok());
  for (int i = 0; i < kNumPoints; ++i) EXPECT_NEAR(((*r)[i] - pl[i]).norm(), 0, 1e-12);
  // A dense polyline: points land equally spaced along the arc.
  std::vector<Vec2> dense;
  for (int i = 0; i <= 1000; ++i) dense.emplace_back(i * 0.001, std::sin(i * 0.003));
  auto d = ResampleByArcLength(dense);
  ASSERT_TRUE(d.ok());
  // Arc position of each resampled point along the dense curve (a graph over x).
  std::vector<double> s(dense.size(), 0.0);
  for (size_t i = 1; i < dense.size(); ++i) s[i] = s[i - 1] + (dense[i] - dense[i - 1]).norm();
  for (int k = 0; k < kNumPoints; ++k) {
    const size_t i = std::min<size_t>(static_cast<size_t>((*d)[k].x() / 0.001), dense.size() - 2);
    const double at = s[i] + ((*d)[k] - dense[i]).norm();
    EXPECT_NEAR(at, s.back() * k / kNumLinks, 1e-9) << k;
  }
  EXPECT_FALSE(ResampleByArcLength({Vec2(0, 0), Vec2(1, 0)}).ok());
}

TEST(Kinematics, UnitsAreConvertedToMm) {
  auto um = ParseKinematics("# fps: 30\n# units: um\n" + Header(3) + Row(0, 3, 100) + Row(1, 3, 100), "u.csv");
  ASSERT_TRUE(um.ok());
  EXPECT_NEAR(um->BodyLength(), 0.2, 1e-12);
  auto px = ParseKinematics("# fps: 30\n# units: px\n# px_per_mm: 50\n" + Header(3) + Row(0, 3, 10) + Row(1, 3, 10),
                            "p.csv");
  ASSERT_TRUE(px.ok());
  EXPECT_NEAR(px->BodyLength(), 0.4, 1e-12);
  auto nopx = ParseKinematics("# fps: 30\n# units: px\n" + Header(3) + Row(0, 3), "p.csv");
  EXPECT_FALSE(nopx.ok());
}

TEST(Kinematics, UncalibratedPixelsAreWrittenAsPixels) {
  auto k = ParseKinematics("# fps: 30\n" + Header(3) + Row(0, 3, 10) + Row(1, 3, 10), "k.csv");
  ASSERT_TRUE(k.ok());
  k->metadata["units"] = "px";  // what an uncalibrated `wormdrag track` produces
  const std::string text = FormatKinematics(*k);
  EXPECT_NE(text.find("# units: px\n"), std::string::npos);
  EXPECT_EQ(text.find("# units: mm"), std::string::npos);
  auto back = ParseKinematics(text, "track.csv");
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.status().message().find("px_per_mm"), std::string::npos);
  EXPECT_NE(back.status().message().find("--um-per-px"), std::string::npos);
  // With the scale added, it reads in mm.
  k->metadata["px_per_mm"] = "100";
  auto scaled = ParseKinematics(FormatKinematics(*k), "track.csv");
  ASSERT_TRUE(scaled.ok()) << scaled.status().ToString();
  EXPECT_NEAR(scaled->BodyLength(), k->BodyLength() / 100, 1e-12);
  EXPECT_NE(FormatKinematics(*scaled).find("# units: mm\n"), std::string::npos);
}

TEST(Kinematics, MissingFrames) {
  const std::string text = "# fps: 10\n" + Header(3) + Row(0, 3) + "0.1,nan,nan,nan,nan,nan,nan\n" +
                           "0.2,,,,,,\n0.3\n" + Row(0.4, 3);
  auto k = ParseKinematics(text, "m.csv");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  ASSERT_EQ(k->frames.size(), 5u);
  EXPECT_EQ(k->NumValid(), 2);
  EXPECT_FALSE(k->frames[1].valid);
  EXPECT_FALSE(k->frames[3].valid);
}

// Each kind of bad file gets an error naming the file, the line and the column.
struct BadCase {
  const char* what;
  std::string text;
  const char* expect;  // substring of the message
};

TEST(Kinematics, ReaderErrors) {
  const std::string h = Header(3);
  const BadCase cases[] = {
      {"missing fps", h + Row(0, 3), "missing required metadata '# fps"},
      {"bad fps", "# fps: fast\n" + h + Row(0, 3), "fps must be a positive number"},
      {"non-numeric cell", "# fps: 10\n" + h + "0,0,0,0.1,abc,0.2,0\n", "bad.csv:3: column 5 (y1): not a number 'abc'"},
      {"malformed row", "# fps: 10\n" + h + "0,0,0,0.1\n", "bad.csv:3: expected 7 columns, got 4"},
      {"too few points", "# fps: 10\nt,x0,y0,x1,y1\n0,0,0,1,1\n", "at least 3 points"},
      {"non-increasing time", "# fps: 10\n" + h + Row(0.1, 3) + Row(0.1, 3), "bad.csv:4: column 1 (t): time"},
      {"bad header", "# fps: 10\nt,x0,y0,x1,z1,x2,y2\n", "column 5: expected 'y1', got 'z1'"},
      {"no header", "# fps: 10\n", "no header row"},
      {"no frames", "# fps: 10\n" + h, "no frames"},
      {"all missing", "# fps: 10\n" + h + "0\n0.1\n", "every frame is missing"},
      {"bad time", "# fps: 10\n" + h + "zero,0,0,1,0,2,0\n", "bad.csv:3: column 1 (t): not a number 'zero'"},
      {"unknown units", "# fps: 10\n# units: inch\n" + h + Row(0, 3), "unknown units 'inch'"},
      {"degenerate skeleton", "# fps: 10\n" + h + "0,1,1,1,1,1,1\n", "bad.csv:3: a skeleton has zero length"},
  };
  for (const auto& c : cases) {
    auto k = ParseKinematics(c.text, "bad.csv");
    ASSERT_FALSE(k.ok()) << c.what;
    EXPECT_EQ(k.status().code(), Status::Code::kInvalidArgument) << c.what;
    EXPECT_NE(k.status().message().find(c.expect), std::string::npos) << c.what << ": " << k.status().message();
  }
  EXPECT_EQ(ReadKinematics("/nonexistent/k.csv").status().code(), Status::Code::kNotFound);
}

TEST(Kinematics, WriteReadRoundTrip) {
  auto k = ParseKinematics("# fps: 10\n# source: test\n" + Header(3) + Row(0, 3) + "0.1\n" + Row(0.2, 3), "k.csv");
  ASSERT_TRUE(k.ok());
  const std::string path = ::testing::TempDir() + "/roundtrip.csv";
  ASSERT_TRUE(WriteKinematics(*k, path).ok());
  auto back = ReadKinematics(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->frames.size(), 3u);
  EXPECT_FALSE(back->frames[1].valid);
  EXPECT_EQ(back->metadata.at("source"), "test");
  for (int i = 0; i < kNumPoints; ++i) EXPECT_NEAR((back->frames[2].p[i] - k->frames[2].p[i]).norm(), 0, 1e-11);
  EXPECT_FALSE(WriteKinematics(*k, "/nonexistent-dir/x.csv").ok());
}

}  // namespace
}  // namespace wormdrag
