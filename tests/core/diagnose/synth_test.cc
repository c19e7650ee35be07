// The synthetic generator: determinism by seed, gaps and the truth file, and the
// tracking-noise estimate.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <gtest/gtest.h>

#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using namespace test;

TEST(Synth, DeterministicBySeed) {
  EffectParams e;
  e.body_gradient = 0.5;
  const auto a = Pair(e, 0.003, 7), b = Pair(e, 0.003, 7), c = Pair(e, 0.003, 8);
  EXPECT_EQ(FormatKinematics(a[0]), FormatKinematics(b[0]));
  EXPECT_NE(FormatKinematics(a[0]), FormatKinematics(c[0]));
}

TEST(Synth, GapsAndTruth) {
  SynthSpec s;
  s.fps = 50;
  s.duration = 1;
  s.gaps.every = 10;
  s.gaps.length = 3;
  s.gaps.first = 5;
  s.effects.gap_offset = 0.5;
  auto r = Synthesize(s);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_FALSE(r->recording.frames[5].valid);
  EXPECT_FALSE(r->recording.frames[7].valid);
  EXPECT_TRUE(r->recording.frames[8].valid);
  EXPECT_TRUE(r->clean.frames[6].valid);
  EXPECT_EQ(Dump(r->truth["effects"]), "{\"gap_offset\":{\"a\":0.5}}");
  EXPECT_EQ(Dump(r->truth["gaps"][0]), "[5,7]");
  // Out-of-catalogue effects are generated too.
  s.effects = EffectParams{};
  s.effects.stretch = 0.1;
  s.effects.tether = 2;
  auto o = Synthesize(s);
  ASSERT_TRUE(o.ok()) << o.status().ToString();
  EXPECT_GT(std::abs(o->clean.frames[10].arc_length - 1.0), 1e-3);
}

TEST(Synth, NoiseEstimate) {
  const auto k = Pair({}, 0.004, 3, 100, 2);
  EXPECT_NEAR(EstimateTrackingNoise(k[0]), 0.004, 0.001);
}

}  // namespace
}  // namespace wormdrag::diagnose
