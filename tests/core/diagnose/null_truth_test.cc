// The noise-only replicates' truth (NullTruth): a periodic gait where the gait explains
// the shapes down to the noise, the prepared shapes where it does not.
#include <cmath>

#include <gtest/gtest.h>

#include "core/model/body.h"
#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using namespace test;

constexpr double kFps = 60, kDuration = 5, kNoise = 0.002;  // mm: 0.2 % of the body

// A pair driven by `shapes` (the pattern when null) with tracking noise, its clean
// recordings, the noisy pair prepared with the estimate's smoothing, and its NullTruth.
struct Made {
  std::array<Kinematics, 2> noisy, clean;
  DiagnoseOptions o;
  EffectData data, truth;
  std::array<double, 2> excess;
};
void MakeTruth(const Kinematics* shapes, Made* m) {
  for (int j = 0; j < 2; ++j) {
    SynthSpec s;
    s.pattern = Locomotion(j + 1);
    s.shapes = shapes;
    s.coef = kTrue;
    s.fps = kFps;
    s.duration = kDuration;
    s.noise = kNoise;
    s.seed = 21 + j;
    s.substeps = 4;
    auto r = Synthesize(s);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    m->noisy[j] = r->recording;
    m->clean[j] = r->clean;
  }
  m->o.smoothing = SmoothingMethod::kAuto;
  auto data = PrepareForDiagnosis(m->noisy, m->o);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  auto truth = NullTruth(m->noisy, *data, m->o, kMaxGaitExcess, &m->excess);
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  m->data = std::move(*data);
  m->truth = std::move(*truth);
}

// RMS difference (rad) of the joint angles of `a`'s valid frames from those of `clean`
// at the same times.
double ShapeRms(const EffectData& a, const std::array<Kinematics, 2>& clean) {
  double sq = 0;
  long n = 0;
  for (int j = 0; j < 2; ++j) {
    for (const Frame& f : a.worms[j].FullRate().frames) {
      if (!f.valid) continue;
      const Frame& c = clean[j].frames.at(std::lround(f.t * kFps));
      const Shape q = ShapeOf(f.p), qc = ShapeOf(c.p);
      for (int i = 0; i < kNumJoints; ++i, ++n) sq += (q[i] - qc[i]) * (q[i] - qc[i]);
    }
  }
  return std::sqrt(sq / n);
}

// On a steady travelling wave the replicates' truth is the gait: the raw shapes' residual
// about it is at the noise, and its shapes are nearer the clean ones than the smoothed
// shapes are, which keep the noise between the gait's harmonics. Both keep the noise at
// the harmonics themselves (a few % of each joint's amplitude at 0.2 % BL): no fit over
// one recording can tell it from the gait.
TEST(NullTruth, ASteadyWaveGivesItsGaitNearerTheCleanShapes) {
  Made m;
  ASSERT_NO_FATAL_FAILURE(MakeTruth(nullptr, &m));
  for (int j = 0; j < 2; ++j) {
    EXPECT_GT(m.excess[j], 0.8);
    EXPECT_LT(m.excess[j], kMaxGaitExcess);
  }
  const double smoothed = ShapeRms(m.data, m.clean), gait = ShapeRms(m.truth, m.clean);
  std::printf("excess %.3g %.3g; shapes vs clean: smoothed %.4g rad, gait %.4g rad\n", m.excess[0], m.excess[1],
              smoothed, gait);
  EXPECT_LT(gait, smoothed);
}

// A wave whose amplitude grows threefold is no periodic gait: its residual is far above
// the noise, and the truth is the prepared data, frame for frame.
TEST(NullTruth, AChangingGaitKeepsThePreparedShapes) {
  Kinematics shapes;
  shapes.fps = kFps;
  const BodyModel body;
  const JointPattern wave = Locomotion(1);
  for (int f = 0; f <= std::lround((kDuration + 0.5) * kFps); ++f) {
    Frame fr;
    fr.t = f / kFps;
    fr.valid = true;
    JointPattern p = wave;
    p.amplitude = 0.2 + 0.4 * fr.t / kDuration;
    Shape q, qd;
    p.Evaluate(fr.t, &q, &qd);
    fr.p = LabPoints(Pose{}, q, body.link_length());
    fr.arc_length = body.length;
    shapes.frames.push_back(fr);
  }
  Made m;
  ASSERT_NO_FATAL_FAILURE(MakeTruth(&shapes, &m));
  for (int j = 0; j < 2; ++j) {
    EXPECT_GT(m.excess[j], kMaxGaitExcess);
    const auto& a = m.data.worms[j].kinematics.frames;
    const auto& b = m.truth.worms[j].kinematics.frames;
    ASSERT_EQ(a.size(), b.size());
    int changed = 0;
    for (size_t f = 0; f < a.size(); ++f) changed += !(a[f].p == b[f].p);
    EXPECT_EQ(changed, 0) << "worm " << j;
  }
}

// Without noise the ratio has no noise to compare with; the truth is still made and
// stays on the data's shapes to within the fit.
TEST(NullTruth, NoiseFreeDataGiveATruthOnTheirShapes) {
  Made m;
  ASSERT_NO_FATAL_FAILURE(MakeTruth(nullptr, &m));
  auto data = PrepareForDiagnosis(m.clean, m.o);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  auto truth = NullTruth(m.clean, *data, m.o);
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  EXPECT_LT(ShapeRms(*truth, m.clean), 1e-3);
}

}  // namespace
}  // namespace wormdrag::diagnose
