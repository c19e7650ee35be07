// Data preparation: the frames the fits use, the held-out blocks, and the smoothing's
// change to the joint angles.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <gtest/gtest.h>

#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using namespace test;

// The low-pass's change to the joint angles ("where", low-pass): a truth driven by
// shapes with fast motion loses much more to the 5 Hz filter than a smooth one, and a
// noise-only replicate of it (whose truth is driven by the filtered shapes) does not
// lose it again. Why it matters: motion faster than the cut-off is an unmodelled effect
// the null cannot see (docs/decisions/0026-benchmark-kymogram-cutoff.md).
TEST(PrepareForDiagnosis, LowPassChangeShowsMotionFasterThanTheCutOff) {
  const auto smooth = Pair({}, 0, 5, 60, 2);
  std::array<Kinematics, 2> fast;
  for (int j = 0; j < 2; ++j) {
    Kinematics jittery = smooth[j];  // shapes with fast motion: 3 µm of jitter on every point
    AddTrackingNoise(&jittery, 0.003, 11 + j);
    SynthSpec s;
    s.shapes = &jittery;
    s.coef = kTrue;
    s.fps = 60;
    s.duration = 1.8;
    s.substeps = 4;
    auto r = Synthesize(s);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    fast[j] = r->recording;  // noise-free: all of the change is motion
  }
  DiagnoseOptions o;
  o.smoothing = SmoothingMethod::kLowpass;
  auto a = PrepareForDiagnosis(smooth, o), b = PrepareForDiagnosis(fast, o);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_GT(b->smoothing_change_rad, 5 * a->smoothing_change_rad);
  EXPECT_GT(b->smoothing_change_rad, 0.01);
  // The null replicate (truth on the filtered shapes, noise of 0.1 µm) loses almost nothing.
  auto null = FitTaskData(fast, o, 1, kTrue, 1e-4);
  ASSERT_TRUE(null.ok()) << null.status().ToString();
  EXPECT_LT(null->smoothing_change_rad, 0.2 * b->smoothing_change_rad);
  // Without the low-pass nothing is changed.
  o.lowpass_hz = 0;
  auto c = PrepareForDiagnosis(fast, o);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->smoothing_change_rad, 0);
}

// The estimate's smoothing (auto: GCV per shape mode) leaves a clean pair's angles all
// but unchanged and takes tracking noise out, where the 5 Hz low-pass changes both.
TEST(PrepareForDiagnosis, AutoSmoothingKeepsCleanShapesAndRemovesNoise) {
  const auto clean = Pair({}, 0, 5, 60, 2);
  auto noisy = clean;
  for (int j = 0; j < 2; ++j) AddTrackingNoise(&noisy[j], 0.002, 21 + j);
  DiagnoseOptions o;
  o.smoothing = SmoothingMethod::kAuto;
  auto a = PrepareForDiagnosis(clean, o), b = PrepareForDiagnosis(noisy, o);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  EXPECT_LT(a->smoothing_change_rad, 1e-3);
  // 2 µm on 0.08 mm links is ~0.035 rad of angle noise; most of it goes.
  EXPECT_GT(b->smoothing_change_rad, 10 * a->smoothing_change_rad);
  o.smoothing = SmoothingMethod::kNone;
  auto c = PrepareForDiagnosis(noisy, o);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->smoothing_change_rad, 0);
}

// Held-out blocks: by default one per 0.5 s of the analysed span (what the benchmark
// measured), at least 2 and at most 100; an explicit count wins.
TEST(BlockCount, HalfSecondBlocksByDefault) {
  DiagnoseOptions o;
  EXPECT_EQ(o.blocks, 0);
  EXPECT_EQ(BlockCount(o, 1.98), 4);
  EXPECT_EQ(BlockCount(o, 4.983), 10);
  EXPECT_EQ(BlockCount(o, 0.3), 2);
  EXPECT_EQ(BlockCount(o, 600), 100);
  o.blocks = 6;
  EXPECT_EQ(BlockCount(o, 4.983), 6);
  EXPECT_TRUE(o.Validate().ok());
  o.blocks = 1;
  EXPECT_FALSE(o.Validate().ok());
  o.blocks = 0;
  EXPECT_TRUE(o.Validate().ok());
  // Through the data the fits use: a 2 s pair at 50 fps has 4 blocks per worm.
  o.smoothing = SmoothingMethod::kNone;
  auto data = PrepareForDiagnosis(Pair({}, 0.0, 3), o);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  EXPECT_EQ(data->blocks, 4);
  for (const auto& w : data->worms) EXPECT_EQ(w.block_starts.size(), 3u);
}

// The fits' frames at fit_hz: every stride-th frame plus the borders of every run of
// missing frames (gap_offset acts across them), far fewer than all.
TEST(FitFrames, StrideAndGapBorders) {
  SynthSpec s;
  s.fps = 300;
  s.duration = 1;
  s.gaps.every = 40;
  s.gaps.length = 7;
  s.gaps.first = 13;
  auto r = Synthesize(s);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->recording;
  const std::vector<int> f = FitFrames(k, 30);
  auto has = [&](int i) { return std::find(f.begin(), f.end(), i) != f.end(); };
  EXPECT_LT(f.size(), k.frames.size() / 4);
  EXPECT_TRUE(has(0));
  EXPECT_TRUE(has(static_cast<int>(k.frames.size()) - 1));
  for (size_t i = 0; i < k.frames.size(); i += 10) EXPECT_TRUE(has(static_cast<int>(i))) << i;
  int runs = 0;
  for (size_t i = 1; i + 1 < k.frames.size(); ++i) {
    if (k.frames[i].valid && !k.frames[i + 1].valid) { EXPECT_TRUE(has(static_cast<int>(i))) << i; }  // before a gap
    if (k.frames[i].valid && !k.frames[i - 1].valid) { EXPECT_TRUE(has(static_cast<int>(i))) << i; }  // after it
    if (!k.frames[i].valid && k.frames[i - 1].valid) {
      EXPECT_TRUE(has(static_cast<int>(i))) << i;
      ++runs;
    }
  }
  EXPECT_GE(runs, 5);
  EXPECT_EQ(FitFrames(k, 0).size(), k.frames.size());
  EXPECT_EQ(FitFrames(k, 400).size(), k.frames.size());
}

// Fitting at a subsampled time resolution costs little accuracy: on clean 150 fps data
// with gaps and a lag, the true model's held-out error at fit_hz 30 (2 knots per fitted
// frame) stays within a small fraction of a µm of the full-rate figure, and the
// subsampled data carry the same gaps.
TEST(FitFrames, SubsampledTruthScoresLikeFullRate) {
  EffectParams e;
  e.lag = 0.05;
  GapPattern gaps;
  gaps.every = 30;
  gaps.length = 5;
  const auto pair = Pair(e, 0.0, 5, 150, 2, gaps);
  DiagnoseOptions full, sub;
  full.fit_hz = 0;
  full.substeps = 1;
  full.blocks = sub.blocks = 4;
  full.interpolate_gaps = sub.interpolate_gaps = 5;
  sub.fit_hz = 30;
  sub.substeps = 2;
  auto df = PrepareForDiagnosis(pair, full), ds = PrepareForDiagnosis(pair, sub);
  ASSERT_TRUE(df.ok() && ds.ok());
  EXPECT_LT(ds->worms[0].kinematics.frames.size() * 3, df->worms[0].kinematics.frames.size());
  EXPECT_EQ(ds->worms[0].drive->gaps().size(), df->worms[0].drive->gaps().size());
  auto e_of = [&](const EffectData& d) {
    const BlockScores b = ScoreBlocks(d, kTrue, e, true, kDefaultEpsilon);
    double a = 0, n = 0;
    for (size_t i = 0; i < b.sum.size(); ++i) {
      a += b.sum[i];
      n += b.count[i];
    }
    return a / n;
  };
  const double ef = e_of(*df), es = e_of(*ds);
  EXPECT_LT(ef, 2e-3);  // the 5 Hz filter alone leaves ~1 µm
  EXPECT_NEAR(es, ef, 3e-4) << "full rate " << ef << " mm, subsampled " << es << " mm";
}

}  // namespace
}  // namespace wormdrag::diagnose
