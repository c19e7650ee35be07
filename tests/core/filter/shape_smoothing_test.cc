#include "core/filter/shape_smoothing.h"

#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "core/filter/butterworth.h"

namespace wormdrag {
namespace {

// A crawling-like recording: the paper's travelling wave at 2 Hz with a 6 Hz
// harmonic, the body gliding forward, 5 s at 300 fps, 1 mm long.
Kinematics Wave(double noise_mm, unsigned seed, std::vector<Shape>* truth = nullptr) {
  Kinematics k;
  k.fps = 300;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, noise_mm);
  const double l = 1.0 / kNumLinks;
  for (int f = 0; f < 1500; ++f) {
    const double t = f / k.fps;
    Shape q;
    for (int i = 0; i < kNumJoints; ++i)
      q[i] = 0.5 * std::sin(2 * M_PI * 2 * t - 0.6 * (i + 1)) + 0.06 * std::sin(2 * M_PI * 6 * t - 1.8 * (i + 1));
    if (truth) truth->push_back(q);
    Frame fr;
    fr.t = t;
    fr.valid = true;
    fr.p = LabPoints({0.2 * t, 0.05 * t, 0.1 * std::sin(t)}, q, l);
    for (Vec2& p : fr.p) p += Vec2(g(rng), g(rng));
    fr.arc_length = ArcLength(std::vector<Vec2>(fr.p.begin(), fr.p.end()));
    k.frames.push_back(fr);
  }
  return k;
}

double ShapeRms(const Kinematics& k, const std::vector<Shape>& truth) {
  double s = 0;
  for (size_t f = 0; f < truth.size(); ++f) {
    const Shape q = ShapeOf(k.frames[f].p);
    for (int i = 0; i < kNumJoints; ++i) s += std::pow(WrapAngle(q[i] - truth[f][i]), 2);
  }
  return std::sqrt(s / (truth.size() * kNumJoints));
}

TEST(ShapeSmoothing, EstimatesTrackingNoiseAndRemovesMostOfItsShapeError) {
  for (double sigma : {0.002, 0.005, 0.01}) {  // 0.2 %, 0.5 %, 1 % of a 1 mm body
    std::vector<Shape> truth;
    const Kinematics noisy = Wave(sigma, 11, &truth);
    SmoothingReport report;
    auto smoothed = SmoothShapesAuto(noisy, {}, &report);
    ASSERT_TRUE(smoothed.ok()) << smoothed.status().ToString();
    EXPECT_NEAR(report.noise_mm, sigma, 0.15 * sigma) << report.ToText();
    EXPECT_NEAR(report.noise_percent_bl, 100 * sigma / noisy.BodyLength(), 0.2 * 100 * sigma);
    const double before = ShapeRms(noisy, truth), after = ShapeRms(*smoothed, truth);
    EXPECT_LT(after, before / 6) << "σ " << sigma << ": " << before << " → " << after;
    EXPECT_EQ(report.runs, 1);
    EXPECT_EQ(report.frames, 1500);
  }
}

// A scaled λ moves the shapes away from GCV's choice in the expected direction: a
// decade less keeps more noise, a decade more also takes gait, both err more.
TEST(ShapeSmoothing, LambdaScaleSmoothsLessOrMoreThanGcvChose) {
  std::vector<Shape> truth;
  const Kinematics noisy = Wave(0.005, 12, &truth);
  SmoothingSplineOptions o;
  std::map<double, double> err;
  for (double scale : {0.01, 1.0, 100.0}) {
    o.lambda_scale = scale;
    SmoothingReport report;
    auto smoothed = SmoothShapesAuto(noisy, o, &report);
    ASSERT_TRUE(smoothed.ok()) << smoothed.status().ToString();
    err[scale] = ShapeRms(*smoothed, truth);
  }
  EXPECT_LT(err[1.0], err[0.01]);
  EXPECT_LT(err[1.0], err[100.0]);
  EXPECT_LT(err[0.01], ShapeRms(noisy, truth));
  o.lambda_scale = 0;
  SmoothingReport report;
  EXPECT_FALSE(SmoothShapesAuto(noisy, o, &report).ok());
}

TEST(ShapeSmoothing, PoseAndLinkLengthLoseTheirNoiseAndTheirBias) {
  const double sigma = 0.005;
  const Kinematics noisy = Wave(sigma, 7);
  SmoothingReport report;
  auto out = SmoothShapesAuto(noisy, {}, &report);
  ASSERT_TRUE(out.ok());
  // Noise lengthens every link by about σ²/l: 0.4 % of the body here.
  EXPECT_GT(noisy.BodyLength(), 1.002);
  EXPECT_NEAR(out->BodyLength(), 1.0, 5e-4);
  // The head-link angle that starts a simulated path: per frame it carries the
  // noise of two points; smoothed, about the shape's remaining error.
  double raw = 0, smoothed = 0;
  for (size_t f = 0; f < noisy.frames.size(); ++f) {
    const double truth = 0.1 * std::sin(noisy.frames[f].t);
    raw += std::pow(WrapAngle(HeadLinkAngle(noisy.frames[f].p) - truth), 2);
    smoothed += std::pow(
        WrapAngle(BestFitPose(out->frames[f].p, ShapeOf(out->frames[f].p), 1.0 / kNumLinks).q0 - truth), 2);
  }
  EXPECT_LT(std::sqrt(smoothed / noisy.frames.size()), 0.2 * std::sqrt(raw / noisy.frames.size()));
}

TEST(ShapeSmoothing, CleanRecordingPassesUnchanged) {
  Kinematics clean = Wave(0, 1);
  for (Frame& f : clean.frames)
    for (Vec2& p : f.p) p = Vec2(std::round(p.x() * 1e8) / 1e8, std::round(p.y() * 1e8) / 1e8);
  SmoothingReport report;
  auto out = SmoothShapesAuto(clean, {}, &report);
  ASSERT_TRUE(out.ok());
  double worst = 0;
  for (size_t f = 0; f < clean.frames.size(); ++f)
    for (int p = 0; p < kNumPoints; ++p) worst = std::max(worst, (out->frames[f].p[p] - clean.frames[f].p[p]).norm());
  EXPECT_LT(worst, 1e-6);  // mm: 1e-4 % of the body length
  EXPECT_LT(report.noise_mm, 1e-6);
}

TEST(ShapeSmoothing, ThePapersLowPassAttenuatesTheGaitTheDefaultKeepsIt) {
  std::vector<Shape> truth;
  const Kinematics clean = Wave(0, 1, &truth);
  AngleFilterOptions lp;
  lp.cutoff_hz = 5;
  auto filtered = FilterJointAngles(clean, lp);
  SmoothingReport report;
  auto smoothed = SmoothShapesAuto(clean, {}, &report);
  ASSERT_TRUE(filtered.ok() && smoothed.ok());
  // 5 Hz removes much of the 6 Hz harmonic (0.06 rad): a shape error of tens of mrad.
  EXPECT_GT(ShapeRms(*filtered, truth), 0.02);
  EXPECT_LT(ShapeRms(*smoothed, truth), 1e-6);
}

TEST(ShapeSmoothing, MissingFramesSplitRunsAndStayMissing) {
  Kinematics k = Wave(0.005, 5);
  for (int f = 700; f < 710; ++f) k.frames[f].valid = false;
  SmoothingReport report;
  auto out = SmoothShapesAuto(k, {}, &report);
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(report.runs, 2);
  EXPECT_EQ(report.frames, 1490);
  for (int f = 700; f < 710; ++f) EXPECT_FALSE(out->frames[f].valid);
}

TEST(ShapeSmoothing, ParsesMethodNames) {
  EXPECT_EQ(*ParseSmoothingMethod("auto"), SmoothingMethod::kAuto);
  EXPECT_EQ(*ParseSmoothingMethod("lowpass"), SmoothingMethod::kLowpass);
  EXPECT_EQ(*ParseSmoothingMethod("none"), SmoothingMethod::kNone);
  EXPECT_FALSE(ParseSmoothingMethod("gcv").ok());
}

}  // namespace
}  // namespace wormdrag
