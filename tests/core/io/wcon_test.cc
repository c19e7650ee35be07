#include "core/io/wcon.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

Kinematics Sample() {
  Kinematics k;
  k.fps = 10;
  k.metadata["environment"] = "agar";
  k.frames.resize(5);
  for (int i = 0; i < 5; ++i) {
    Frame& f = k.frames[i];
    f.t = i / 10.0;
    f.valid = i != 2;
    Shape q;
    for (int j = 0; j < kNumJoints; ++j) q[j] = 0.2 * std::sin(i - 0.5 * j);
    f.p = LabPoints({0.1 * i, 0.2, 0.3}, q, 1.0 / kNumLinks);
    f.arc_length = 1.0;
  }
  return k;
}

TEST(Wcon, RoundTripKeepsFramesAndGaps) {
  const Kinematics k = Sample();
  auto back = ParseWcon(FormatWcon(k), {}, "mem.wcon");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->frames.size(), 5u);
  EXPECT_NEAR(back->fps, 10, 1e-12);
  EXPECT_FALSE(back->frames[2].valid);
  EXPECT_EQ(back->metadata["environment"], "agar");
  for (int i : {0, 1, 3, 4})
    for (int j = 0; j < kNumPoints; ++j) EXPECT_LT((back->frames[i].p[j] - k.frames[i].p[j]).norm(), 1e-9);
}

TEST(Wcon, ReadsUnitsOffsetsAndDroppedFrames) {
  // Two records of worm "a" (merged by time), one of worm "b"; micrometres, ms, an origin
  // offset, and a time step of 3 frames: the two frames between are missing.
  const std::string text = R"({
    "units": {"t": "ms", "x": "um", "y": "um"},
    "data": [
      {"id": "a", "t": [0, 100], "x": [[0, 500, 1000], [0, 500, 1000]], "y": [[0, 0, 0], [0, 0, 0]], "ox": 1000},
      {"id": "b", "t": [0], "x": [[0, 1, 2]], "y": [[0, 0, 0]]},
      {"id": "a", "t": [400], "x": [[0, 500, 1000]], "y": [[10, 10, 10]], "ox": 1000}
    ]})";
  auto k = ParseWcon(text, {}, "t.wcon");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  EXPECT_NEAR(k->fps, 10, 1e-9);
  ASSERT_EQ(k->frames.size(), 5u);
  EXPECT_TRUE(k->frames[0].valid);
  EXPECT_FALSE(k->frames[2].valid);
  EXPECT_FALSE(k->frames[3].valid);
  EXPECT_TRUE(k->frames[4].valid);
  EXPECT_NEAR(k->frames[0].p[0].x(), 1.0, 1e-12);  // (0 + 1000 µm) → 1 mm
  EXPECT_NEAR(k->frames[4].p[13].x(), 2.0, 1e-12);
  EXPECT_NEAR(k->frames[4].p[0].y(), 0.01, 1e-12);
  auto b = ParseWcon(text, {"b", 0}, "t.wcon");
  EXPECT_FALSE(b.ok());  // one time only: no frame rate
  EXPECT_TRUE(ParseWcon(text, {"b", 5.0}, "t.wcon").ok());
}

TEST(Wcon, ErrorsNameTheField) {
  auto r = ParseWcon(R"({"data": []})", {}, "x.wcon");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("units"), std::string::npos);
  r = ParseWcon(R"({"units": {"t": "s", "x": "furlong", "y": "mm"}, "data": []})", {}, "x.wcon");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("furlong"), std::string::npos);
  EXPECT_FALSE(ParseWcon("{not json", {}, "x.wcon").ok());
}

}  // namespace
}  // namespace wormdrag
