// Tests of core/analysis/progress: the travel along and across the body that a set
// reproduces, on pairs from the model's own simulator, and with a sideways drift
// added to the recorded points that no friction law produces.
#include <cmath>

#include <gtest/gtest.h>

#include "core/analysis/progress.h"
#include "core/estimate/estimator.h"
#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

const Coefficients kTruth{0.4, 0.2, 0.004, 0.002};
// One period of the paper's pattern (ω = 5 rad/s): a stretch this long holds the gait's
// net travel, not a phase of its recoil.
const double kPeriod = 2 * M_PI / 5;

Kinematics Generated(int loco) {
  RecordingSpec spec;
  spec.fps = 30;
  spec.duration = 3 * kPeriod;
  spec.as_estimated = true;  // the estimator's own drive: the truth reproduces the points
  auto k = GenerateRecording(Locomotion(loco), kTruth, SimOptions{}, spec);
  EXPECT_TRUE(k.ok()) << k.status().ToString();
  return *k;
}

// Every point of frame f moved by rate · t_f along the recording's mean body axis turned
// +90°: the body is carried sideways at `rate` mm/s.
Kinematics CarriedSideways(Kinematics k, double rate) {
  Vec2 axis = Vec2::Zero();
  for (const Frame& f : k.frames) axis += f.p[0] - f.p[kNumLinks];
  axis.normalize();
  const Vec2 side(-axis.y(), axis.x());
  for (Frame& f : k.frames)
    for (Vec2& p : f.p) p += rate * f.t * side;
  return k;
}

std::shared_ptr<const PairedPath> Pair(const Kinematics& a, const Kinematics& b) {
  EvaluationOptions o;
  o.t_max = 3 * kPeriod;
  o.substeps = 4;
  o.restart_every = kPeriod;
  auto p = PairedPath::Create({a, b}, {"a", "b"}, o);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return *p;
}

std::vector<double> Column(const ProgressComparison& pr, int worm, int set, bool along) {
  std::vector<double> v;
  for (const auto& s : pr.stretches)
    if (s.worm == worm)
      v.push_back(set < 0 ? (along ? s.measured_along : s.measured_side) : (along ? s.along[set] : s.side[set]));
  return v;
}

TEST(Progress, TheTruthReproducesTheTravelAndTheStillBodyDoesNot) {
  const auto pair = Pair(Generated(1), Generated(2));
  auto pr = CompareProgress(*pair, {kTruth, StillBody()});
  ASSERT_TRUE(pr.ok()) << pr.status().ToString();
  for (int j = 0; j < 2; ++j) {
    const ProgressMean measured = MeanOverStretches(Column(*pr, j, -1, true));
    const ProgressMean side = MeanOverStretches(Column(*pr, j, -1, false));
    ASSERT_EQ(measured.n, 3);
    // Over whole periods the body travels along itself, not sideways.
    EXPECT_GT(std::abs(measured.mean), 0.02);
    EXPECT_LT(std::abs(side.mean), 0.2 * std::abs(measured.mean));
    const ProgressMean truth = MeanOverStretches(Column(*pr, j, 0, true));
    EXPECT_NEAR(truth.mean, measured.mean, 1e-6 * std::abs(measured.mean));
    EXPECT_NEAR(MeanOverStretches(Column(*pr, j, 0, false)).mean, side.mean, 1e-6 * std::abs(measured.mean));
    // Isotropic drag propels nothing: its along-body travel is a small fraction.
    EXPECT_LT(std::abs(MeanOverStretches(Column(*pr, j, 1, true)).mean), 0.1 * std::abs(measured.mean));
  }
}

TEST(Progress, ASidewaysDriftIsMeasuredAndMissedByEveryLaw) {
  const double rate = 0.02;  // mm/s
  const Kinematics a = Generated(1), b = Generated(2);
  auto plain = CompareProgress(*Pair(a, b), {kTruth});
  auto carried = CompareProgress(*Pair(CarriedSideways(a, rate), b), {kTruth});
  ASSERT_TRUE(plain.ok() && carried.ok());
  ASSERT_EQ(plain->stretches.size(), carried->stretches.size());
  for (size_t i = 0; i < plain->stretches.size(); ++i) {
    const auto& p = plain->stretches[i];
    const auto& c = carried->stretches[i];
    // The simulation restarts from the carried pose and is translation invariant.
    EXPECT_NEAR(c.side[0], p.side[0], 1e-9);
    EXPECT_NEAR(c.along[0], p.along[0], 1e-9);
  }
  const ProgressMean missed0 = [&] {
    std::vector<double> v;
    for (const auto& s : carried->stretches)
      if (s.worm == 0) v.push_back(s.measured_side - s.side[0]);
    return MeanOverStretches(v);
  }();
  // Each stretch's own axis is within a few degrees of the recording's mean axis.
  EXPECT_NEAR(missed0.mean, rate, 0.05 * rate);
  EXPECT_LT(missed0.p_zero, 1e-3);
  // The other worm is untouched: the truth misses nothing there.
  for (const auto& s : carried->stretches)
    if (s.worm == 1) { EXPECT_NEAR(s.measured_side, s.side[0], 1e-3 * rate); }
}

TEST(Progress, RefusesNoSetAndASinglePoint) {
  const auto pair = Pair(Generated(1), Generated(2));
  EXPECT_EQ(CompareProgress(*pair, {}).status().code(), Status::Code::kInvalidArgument);
  EvaluationOptions o;
  o.t_max = 1;
  o.points = {7};
  auto one = PairedPath::Create({Generated(1), Generated(2)}, {"a", "b"}, o);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(CompareProgress(**one, {kTruth}).status().code(), Status::Code::kInvalidArgument);
}

TEST(Progress, MeanOverStretchesTestsAZeroMean) {
  const ProgressMean m = MeanOverStretches({1.0, 1.2, 0.8, 1.1, 0.9});
  EXPECT_EQ(m.n, 5);
  EXPECT_DOUBLE_EQ(m.mean, 1.0);
  EXPECT_NEAR(m.se, std::sqrt(0.025 / 5), 1e-12);
  EXPECT_LT(m.p_zero, 1e-3);
  EXPECT_GT(MeanOverStretches({1.0, -1.1, 0.9, -1.0}).p_zero, 0.5);
  EXPECT_TRUE(std::isnan(MeanOverStretches({1.0}).se));
}

}  // namespace
}  // namespace wormdrag
