// gap_offset's mark in a base fit's residual (gap_signature.h): known ratios from
// hand-made windows, and the mark on synthetic recordings with and without the effect.
#include "core/diagnose/gap_signature.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/diagnose/diagnosis.h"
#include "core/diagnose/synth.h"

namespace wormdrag::diagnose {
namespace {

// Windows whose residual change is `ratio` × the model's displacement along it, plus
// an alternating ±jitter along it and a sideways part (which the ratio ignores).
std::vector<GapWindow> Windows(int n, double ratio, double jitter) {
  std::vector<GapWindow> w;
  for (int k = 1; k <= n; ++k) {
    const Vec2 dc(0.01 * k, 0.005);
    const Vec2 along = dc.normalized(), side(-along.y(), along.x());
    w.push_back({ratio * dc + (k % 2 ? jitter : -jitter) * along + 0.003 * side, dc});
  }
  return w;
}

TEST(GapSignature, ExcessIsTheRatioAtTheRunsOverTheRatioElsewhere) {
  const GapSignature g = SummariseGapWindows(Windows(20, 0.5, 1e-4), Windows(40, 0.1, 1e-4));
  ASSERT_TRUE(g.Measured());
  EXPECT_EQ(g.gaps, 20);
  EXPECT_EQ(g.windows, 40);
  EXPECT_NEAR(g.at_gaps, 0.5, 0.01);
  EXPECT_NEAR(g.elsewhere, 0.1, 0.01);
  EXPECT_NEAR(g.excess, 0.4, 0.01);
  EXPECT_GT(g.Z(), 20);
  // The same ratio everywhere (a path that progresses too little overall) shows none.
  const GapSignature same = SummariseGapWindows(Windows(20, 0.1, 1e-4), Windows(40, 0.1, 1e-4));
  EXPECT_LT(std::abs(same.Z()), 1);
  // More jitter, a larger standard error.
  EXPECT_GT(SummariseGapWindows(Windows(20, 0.5, 1e-3), Windows(40, 0.1, 1e-3)).se, 5 * g.se);
}

TEST(GapSignature, NotMeasuredWithoutWindows) {
  const GapSignature g = SummariseGapWindows({}, Windows(10, 0.1, 1e-4));
  EXPECT_FALSE(g.Measured());
  EXPECT_EQ(g.Z(), 0);
}

// A 60 fps pair with a run of 2 dropped frames every 15 frames and 2 µm of tracking
// noise, prepared as the diagnosis prepares it (gaps interpolated for the smoothing, fits
// at 30 Hz), with `smoothing`.
EffectData Prepared(double gap_offset, uint64_t seed, SmoothingMethod smoothing = SmoothingMethod::kAuto) {
  std::array<Kinematics, 2> pair;
  for (int j = 0; j < 2; ++j) {
    SynthSpec s;
    s.pattern = Locomotion(j + 1);
    s.coef = {0.6, 0.2, 0.006, 0.002};
    s.effects.gap_offset = gap_offset;
    s.fps = 60;
    s.duration = 4;
    s.noise = 0.002;
    s.seed = seed + j;
    s.gaps.every = 15;
    s.gaps.length = 2;
    auto r = Synthesize(s);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    pair[j] = r->recording;
  }
  DiagnoseOptions o;
  o.interpolate_gaps = 3;
  o.smoothing = smoothing;
  auto d = PrepareForDiagnosis(pair, o);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return std::move(*d);
}

TEST(GapSignature, RecoversTheOffsetFromTheResidualAlone) {
  const Coefficients truth{0.6, 0.2, 0.006, 0.002};
  // The low-pass filters the joint angles only: the jump is recovered.
  const GapSignature g = MeasureGapSignature(Prepared(0.6, 11, SmoothingMethod::kLowpass), truth, kDefaultEpsilon);
  ASSERT_TRUE(g.Measured());
  EXPECT_GE(g.gaps, 2 * 14);
  EXPECT_NEAR(g.excess, 0.6, std::max(0.05, 3 * g.se)) << "se " << g.se;
  EXPECT_GT(g.Z(), 8);
  // The default smoothing (auto) also smooths the pose, across the interpolated runs, and
  // spreads part of each jump over the frames beside the run: the mark stays clear but
  // reads low (0.50 of 0.6 on this pair).
  const GapSignature a = MeasureGapSignature(Prepared(0.6, 11), truth, kDefaultEpsilon);
  EXPECT_GT(a.Z(), 8);
  EXPECT_GT(a.excess, 0.4);
  EXPECT_LT(a.excess, g.excess);
}

TEST(GapSignature, AbsentWithoutTheEffectEvenUnderAWrongModel) {
  const EffectData d = Prepared(0.0, 11);
  const GapSignature truth = MeasureGapSignature(d, {0.6, 0.2, 0.006, 0.002}, kDefaultEpsilon);
  ASSERT_TRUE(truth.Measured());
  EXPECT_LT(std::abs(truth.Z()), 3) << "excess " << truth.excess << " se " << truth.se;
  // Half the anisotropy: the model falls behind everywhere, at the runs and elsewhere
  // alike, so the ratios move together and their difference stays at noise.
  const GapSignature wrong = MeasureGapSignature(d, {0.3, 0.2, 0.003, 0.002}, kDefaultEpsilon);
  ASSERT_TRUE(wrong.Measured());
  EXPECT_GT(std::abs(wrong.elsewhere), 0.2) << "the wrong model must fall behind for this test to mean anything";
  EXPECT_LT(std::abs(wrong.Z()), 3) << "excess " << wrong.excess << " se " << wrong.se;
}

}  // namespace
}  // namespace wormdrag::diagnose
