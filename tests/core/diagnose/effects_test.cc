// Effect definitions (docs/conventions.md §5 catalogue) and the effect-aware simulator.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/diagnose/effect_sim.h"
#include "core/diagnose/effects.h"
#include "core/diagnose/synth.h"
#include "core/sim/pattern.h"
#include "core/sim/pose_step.h"
#include "core/sim/simulator.h"
#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using test::MaxPoseDistance;

const Coefficients kF{0.62, 0.21, 0.0071, 0.0013};

Kinematics Recording(double fps, double duration, const Coefficients& c) {
  SimOptions sim;
  sim.solver = Solver::kQuasiStatic;
  RecordingSpec spec;
  spec.fps = fps;
  spec.duration = duration;
  spec.substeps = 2;
  auto k = GenerateRecording(Locomotion(2), c, sim, spec);
  EXPECT_TRUE(k.ok()) << k.status().ToString();
  return *k;
}

EffectDrive Drive(const Kinematics& k, int substeps = 2) {
  BodyModel body;
  body.length = k.BodyLength();
  auto d = EffectDrive::FromKinematics(k, body, substeps);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return *d;
}

TEST(Effects, CatalogueNamesAreBinding) {
  const char* names[] = {"body_gradient", "time_drift", "power_law",  "stiction",
                         "lag",           "flow",       "gap_offset", "lateral_asymmetry"};
  for (int i = 0; i < kNumCatalogue; ++i) {
    EXPECT_STREQ(AllEffects()[i].name, names[i]);
    EXPECT_TRUE(AllEffects()[i].in_catalogue);
    auto e = ParseEffectName(names[i]);
    ASSERT_TRUE(e.ok());
    EXPECT_EQ(static_cast<int>(*e), i);
  }
  EXPECT_FALSE(InfoOf(Effect::kStretch).in_catalogue);
  EXPECT_FALSE(InfoOf(Effect::kTether).in_catalogue);
  EXPECT_FALSE(ParseEffectName("viscosity").ok());
}

TEST(Effects, ParseAndPrint) {
  auto p = ParseEffects({"body_gradient=0.5;flow=0.01,-0.02", "power_law=0.6"});
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_DOUBLE_EQ(p->body_gradient, 0.5);
  EXPECT_DOUBLE_EQ(p->flow_x, 0.01);
  EXPECT_DOUBLE_EQ(p->flow_y, -0.02);
  EXPECT_TRUE(p->power_law);
  EXPECT_DOUBLE_EQ(p->power_n, 0.6);
  EXPECT_FALSE(p->IsNeutral());
  EXPECT_EQ(p->ToString(), "body_gradient=0.5;power_law=0.6;flow=0.01,-0.02");
  EXPECT_FALSE(ParseEffects({"flow=0.1"}).ok());  // two values needed
  EXPECT_FALSE(ParseEffects({"stiction=abc"}).ok());
  EXPECT_FALSE(ParseEffects({"body_gradient=5"}).ok());  // coefficients would turn negative
  EXPECT_TRUE(ParseEffects({"none"})->IsNeutral());
}

TEST(Effects, BodyGradientScalesLinkK) {
  // s_k = (k − ½)/N: link 1 gets 1 + a (1/26 − ½), the middle link 7 exactly 1.
  EXPECT_DOUBLE_EQ(BodyGradientFactor(0.6, 1), 1 + 0.6 * (0.5 / 13 - 0.5));
  EXPECT_DOUBLE_EQ(BodyGradientFactor(0.6, 7), 1.0);
  EXPECT_DOUBLE_EQ(BodyGradientFactor(0.6, 13), 1 + 0.6 * (12.5 / 13 - 0.5));
  // In the wrench: a knot's force with only link 13 moving is scaled by that factor.
  KnotGeometry g{};
  g.jx[24] = 1;  // tangential term of link 13
  g.b[24] = 0.3;
  EffectParams p;
  p.body_gradient = 0.6;
  const auto w0 = EffectWrench(g, kF, {}, 0.5, 1e-4, {0, 0, 0});
  const auto w1 = EffectWrench(g, kF, p, 0.5, 1e-4, {0, 0, 0});
  EXPECT_NEAR(w1[0] / w0[0], BodyGradientFactor(0.6, 13), 1e-12);
}

TEST(Effects, TimeDriftScalesNormalPairOnly) {
  KnotGeometry g{};
  g.jx[1] = 1;
  g.b[1] = 0.2;  // a normal term
  g.jy[0] = 1;
  g.b[0] = 0.2;  // a tangential term
  EffectParams p;
  p.time_drift = 0.8;
  for (double tau : {0.0, 0.5, 1.0}) {
    const auto w0 = EffectWrench(g, kF, {}, tau, 1e-4, {0, 0, 0});
    const auto w1 = EffectWrench(g, kF, p, tau, 1e-4, {0, 0, 0});
    EXPECT_NEAR(w1[0] / w0[0], 1 + 0.8 * (tau - 0.5), 1e-12) << tau;
    EXPECT_NEAR(w1[1] / w0[1], 1.0, 1e-12) << tau;
  }
}

TEST(Effects, PowerLawEqualsAffineAtVRef) {
  EffectParams p;
  p.power_law = true;
  for (double n : {0.3, 0.7, 1.4}) {
    p.power_n = n;
    double f, df, f0, df0;
    EffectForce(kPowerLawVRef, 0.4, 0.006, false, p, 1e-9, &f, &df);
    EffectForce(kPowerLawVRef, 0.4, 0.006, false, EffectParams{}, 1e-9, &f0, &df0);
    EXPECT_NEAR(f, f0, 1e-9 * f0) << n;
    EffectForce(-kPowerLawVRef, 0.4, 0.006, false, p, 1e-9, &f, &df);
    EXPECT_NEAR(f, -f0, 1e-9 * f0) << n;
    // Sublinear (n < 1) force grows more slowly than the speed above v_ref.
    EffectForce(2 * kPowerLawVRef, 0.4, 0.006, false, p, 1e-9, &f, &df);
    EXPECT_NEAR(f / f0, std::pow(2.0, n), 1e-9) << n;
  }
}

TEST(Effects, StictionLimitAndDecay) {
  EffectParams p;
  p.stiction = 1.5;
  double f, df, f0, df0;
  // Just above the smoothing width the Coulomb part is μ (1 + a).
  EffectForce(1e-6, 0.4, 0.0, false, p, 1e-9, &f, &df);
  EXPECT_NEAR(f, 0.4 * 2.5, 1e-6);
  // Far above v_s it is back to μ.
  EffectForce(20 * kStictionVs, 0.4, 0.0, false, p, 1e-9, &f, &df);
  EffectForce(20 * kStictionVs, 0.4, 0.0, false, EffectParams{}, 1e-9, &f0, &df0);
  EXPECT_NEAR(f, f0, 1e-12);
  // Non-monotone: the force falls with speed between the peak and v_s.
  EffectForce(kStictionVs, 0.4, 0.001, false, p, 1e-4, &f, &df);
  EXPECT_LT(df, 0);
}

TEST(Effects, DerivativesMatchFiniteDifferences) {
  EffectParams p;
  p.stiction = 0.8;
  p.lateral_asymmetry = 0.5;
  for (bool pl : {false, true}) {
    p.power_law = pl;
    p.power_n = 0.6;
    for (double v : {-0.3, -0.01, -2e-4, 3e-5, 0.015, 0.2}) {
      double f, df, fp, fm, d;
      EffectForce(v, 0.4, 0.006, true, p, 1e-4, &f, &df);
      const double h = 1e-7 * std::max(1e-3, std::abs(v));
      EffectForce(v + h, 0.4, 0.006, true, p, 1e-4, &fp, &d);
      EffectForce(v - h, 0.4, 0.006, true, p, 1e-4, &fm, &d);
      EXPECT_NEAR(df, (fp - fm) / (2 * h), 1e-4 * std::abs(df) + 1e-6) << v << " power " << pl;
    }
  }
}

TEST(Effects, LateralAsymmetrySign) {
  EffectParams p;
  p.lateral_asymmetry = 0.5;
  double fpos, fneg, d;
  // Sliding toward +n is resisted by μ_n (1 + a), toward −n by μ_n.
  EffectForce(0.05, 0.4, 0.0, true, p, 1e-6, &fpos, &d);
  EffectForce(-0.05, 0.4, 0.0, true, p, 1e-6, &fneg, &d);
  EXPECT_NEAR(fpos, 0.4 * 1.5, 1e-6);
  EXPECT_NEAR(fneg, -0.4, 1e-6);
  // Tangential terms are unaffected.
  EffectForce(0.05, 0.4, 0.0, false, p, 1e-6, &fpos, &d);
  EXPECT_NEAR(fpos, 0.4, 1e-6);
}

TEST(EffectSim, NeutralMatchesCoreQuasiStatic) {
  const Kinematics k = Recording(300, 2, kF);
  const EffectDrive d = Drive(k);
  SimOptions so;
  so.solver = Solver::kQuasiStatic;
  const Trajectory base = Simulator::Simulate(d.drive(), kF, so);
  ASSERT_TRUE(base.summary.ok());
  const EffectTrajectory e = SimulateEffects(d, kF, EffectParams{}, {});
  ASSERT_TRUE(e.ok());
  const double L = d.drive().body().length, l = d.drive().body().link_length();
  double worst = 0;
  for (int fi = 0; fi < d.drive().num_frames(); ++fi) {
    const Points a = LabPoints(base.poses[fi], d.drive().FrameShape(fi), l);
    const Points b = LabPoints(e.poses[fi], d.drive().FrameShape(fi), l);
    for (int p = 0; p < kNumPoints; ++p) worst = std::max(worst, (a[p] - b[p]).norm() / L);
  }
  EXPECT_LT(worst, 1e-9);
  // ... and with effects switched on but at their neutral values.
  EffectParams z;
  z.power_law = false;
  z.flow_x = z.flow_y = 0;
  EXPECT_LT(MaxPoseDistance(d, SimulateEffects(d, kF, z, {}), e), 1e-12);
}

// The poses of the knot velocities xi by the shared pose step (core/sim/pose_step.h),
// one per frame, from the drive's initial pose.
std::vector<Pose> StepPoses(const ShapeDrive& drive, const std::vector<std::array<double, 3>>& xi,
                            const double* medium) {
  const auto& knots = drive.knots();
  std::vector<Pose> poses{drive.initial_pose()};
  Pose g = poses[0];
  for (size_t j = 0; j + 1 < knots.size(); ++j) {
    double xm[3];
    MidpointXi(
        MidpointCubicAt(knots, j), [&](int k, int r) { return xi[k][r]; }, xm);
    PoseRk4Step(knots[j + 1].t - knots[j].t, xi[j].data(), xm, xi[j + 1].data(), medium, &g);
    if ((j + 1) % drive.substeps() == 0) poses.push_back(g);
  }
  return poses;
}

// Exact equality, pose by pose; the count of poses that differ in any bit.
int PosesThatDiffer(const std::vector<Pose>& a, const std::vector<Pose>& b) {
  EXPECT_EQ(a.size(), b.size());
  int differ = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    differ += a[i].x != b[i].x || a[i].y != b[i].y || a[i].q0 != b[i].q0;
  return differ;
}

TEST(EffectSim, PoseIntegrationIsCoreSims) {
  // Both simulators step the pose with core/sim/pose_step.h: given the same knot
  // velocities they give the same poses, bit for bit, so the 1e-9 BL between them above
  // is their knot solvers' alone.
  const Kinematics k = Recording(300, 1, kF);
  const EffectDrive d = Drive(k);
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    SimOptions so;
    so.solver = s;
    so.record_velocities = true;
    const Trajectory t = Simulator::Simulate(d.drive(), kF, so);
    ASSERT_TRUE(t.summary.ok());
    EXPECT_EQ(PosesThatDiffer(StepPoses(d.drive(), t.knot_velocities, nullptr), t.poses), 0) << SolverName(s);
  }
  EffectParams flow, lag;
  flow.flow_x = 0.03;
  flow.flow_y = -0.01;
  lag.lag = 0.05;
  for (const EffectParams& e : {EffectParams{}, flow, lag}) {
    const EffectTrajectory t = SimulateEffects(d, kF, e, {});
    ASSERT_TRUE(t.ok());
    const double medium[2] = {e.flow_x, e.flow_y};
    EXPECT_EQ(PosesThatDiffer(StepPoses(d.drive(), t.knot_velocities, medium), t.poses), 0) << e.ToString();
  }
}

TEST(EffectSim, PowerLawWithUnitExponentIsPureViscous) {
  // n = 1: f = (μ + η v_ref) v / v_ref (up to ε) — the viscous law with η' = μ/v_ref + η.
  const Kinematics k = Recording(300, 1, kF);
  const EffectDrive d = Drive(k);
  EffectParams p;
  p.power_law = true;
  p.power_n = 1;
  const Coefficients viscous{0, 0, kF.mu_n / kPowerLawVRef + kF.eta_n, kF.mu_t / kPowerLawVRef + kF.eta_t};
  EffectSimOptions o;
  o.epsilon = 1e-7;
  const auto a = SimulateEffects(d, kF, p, o), b = SimulateEffects(d, viscous, {}, o);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LT(MaxPoseDistance(d, a, b), 1e-5);
}

TEST(EffectSim, FlowIsRelativeVelocity) {
  // Friction acts on the velocity relative to the medium: the path is the still-medium
  // path carried along by w (exactly).
  const Kinematics k = Recording(300, 1, kF);
  const EffectDrive d = Drive(k);
  EffectParams p;
  p.flow_x = 0.03;
  p.flow_y = -0.01;
  const auto a = SimulateEffects(d, kF, p, {}), b = SimulateEffects(d, kF, {}, {});
  ASSERT_TRUE(a.ok() && b.ok());
  double worst = 0;
  for (int fi = 0; fi < d.drive().num_frames(); ++fi) {
    const double t = d.drive().knots()[fi * d.drive().substeps()].t - d.t0();
    worst = std::max(worst,
                     std::hypot(a.poses[fi].x - b.poses[fi].x - 0.03 * t, a.poses[fi].y - b.poses[fi].y + 0.01 * t));
    worst = std::max(worst, std::abs(a.poses[fi].q0 - b.poses[fi].q0));
  }
  EXPECT_LT(worst, 1e-10);
  // And every knot still balances the friction of the relative velocity.
  const auto w = EffectWrench(d.drive().knots()[10], kF, p, 0.1, kDefaultEpsilon, a.knot_velocities[10]);
  EXPECT_LT(std::abs(w[0]) + std::abs(w[1]) + std::abs(w[2]), 1e-8);
}

TEST(EffectSim, LagShiftsTime) {
  // With a lag δ the rigid velocity at t is the unlagged one at t − δ.
  const Kinematics k = Recording(300, 1.5, kF);
  const EffectDrive d = Drive(k, 1);
  EffectParams p;
  p.lag = 0.1;  // = 30 frames
  const auto a = SimulateEffects(d, kF, p, {}), b = SimulateEffects(d, kF, {}, {});
  ASSERT_TRUE(a.ok() && b.ok());
  for (int j : {60, 200, 400})
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a.knot_velocities[j][c], b.knot_velocities[j - 30][c], 1e-5) << j;
  // Before the first frame the shape is held at its first value, so the path differs.
  EXPECT_GT(MaxPoseDistance(d, a, b), 1e-3);
}

TEST(EffectSim, StictionSolvesRobustly) {
  // A strongly non-monotone law: every knot still converges and balances.
  const Kinematics k = Recording(300, 1.5, kF);
  const EffectDrive d = Drive(k, 1);
  EffectParams p;
  p.stiction = 3.0;
  const auto a = SimulateEffects(d, kF, p, {});
  EXPECT_TRUE(a.ok()) << a.unconverged;
  double worst = 0;
  for (size_t j = 0; j < d.drive().knots().size(); j += 7) {
    const auto w = EffectWrench(d.drive().knots()[j], kF, p, 0.5, kDefaultEpsilon, a.knot_velocities[j]);
    worst = std::max(worst, std::abs(w[0]) + std::abs(w[1]) + std::abs(w[2]));
  }
  EXPECT_LT(worst, 1e-6);
  // And the path is measurably different from the base one.
  EXPECT_GT(MaxPoseDistance(d, a, SimulateEffects(d, kF, {}, {})), 1e-4);
  // The solver also converges from a cold start far away.
  std::array<double, 3> xi{5, -5, 20};
  long it = 0;
  EXPECT_TRUE(
      SolveEffectKnot(d.drive().knots()[100], kF, p, 0.5, kDefaultEpsilon, {0, 0, 0}, 1.0, 1e-9, 200, &xi, &it));
}

TEST(EffectSim, StictionPathConvergesAsTheKnotsRefine) {
  // The non-monotone law's velocity (the least root of its balance) may jump between
  // roots, but the path must still converge as the knots refine: measured third order
  // (1.5 nm at one knot per 60 fps frame, the fits' spacing, from a 64-knot reference;
  // effect ~1 µm).
  const Kinematics k = Recording(60, 2, kF);
  EffectParams p;
  p.stiction = 5.0;
  const EffectDrive ref = Drive(k, 64);
  const auto truth = SimulateEffects(ref, kF, p, {});
  ASSERT_TRUE(truth.ok());
  std::vector<double> err;
  for (int s : {1, 2, 4, 8}) {
    const EffectDrive d = Drive(k, s);
    const auto t = SimulateEffects(d, kF, p, {});
    ASSERT_TRUE(t.ok()) << s;
    err.push_back(MaxPoseDistance(d, t, truth));
  }
  for (size_t i = 0; i + 1 < err.size(); ++i) EXPECT_GT(err[i] / err[i + 1], 4.0) << i;  // order ≥ 2
  EXPECT_LT(err[0], 1e-2 * MaxPoseDistance(ref, truth, SimulateEffects(ref, kF, {}, {})));
}

TEST(EffectSim, StrongStictionPathIsAStableFunctionOfItsDrive) {
  // Stribeck friction makes Φ non-convex; the velocity must be its least root, a
  // function of the shape alone, not whichever root Newton reaches from the last knot's.
  // Then the model driven by a noise-free recording's splined joint angles (not the
  // analytic ones the recording was made with) follows that recording at strong
  // stiction as closely as at none (docs/decisions/0025-stiction-least-root.md).
  for (int pattern : {1, 2}) {
    double stray[3];
    const double strengths[3] = {0, 2.5, 5};
    for (int i = 0; i < 3; ++i) {
      SynthSpec s;
      s.pattern = Locomotion(pattern);
      s.fps = 60;
      s.duration = 5;
      s.substeps = 10;
      s.coef = {0.75, 0.27, 0.0069, 0.0023};
      s.effects.stiction = strengths[i];
      auto r = Synthesize(s);
      ASSERT_TRUE(r.ok()) << r.status().ToString();
      const EffectDrive d = Drive(r->recording, 10);
      const auto t = SimulateEffects(d, s.coef, s.effects, {});
      ASSERT_TRUE(t.ok());
      stray[i] = 0;
      for (int f = d.drive().first_frame(); f <= d.drive().last_frame(); ++f) {
        const Points sim = EffectPoints(d, t, f);
        for (int k = 0; k < kNumPoints; ++k)
          stray[i] = std::max(stray[i], (sim[k] - r->recording.frames[f].p[k]).norm());
      }
    }
    // Measured: ≤ 1e-6 mm at every strength (the none path's own error); the nearest root
    // strayed by 2 µm at a = 2.5 on pattern 1.
    for (int i = 1; i < 3; ++i) EXPECT_LT(stray[i], 1e-5) << "pattern " << pattern << ", a = " << strengths[i];
  }
}

TEST(EffectSim, GapOffsetDisplacesAcrossGaps) {
  Kinematics k = Recording(100, 2, kF);
  for (int f = 50; f < 56; ++f) k.frames[f].valid = false;  // one gap
  const EffectDrive d = Drive(k, 1);
  ASSERT_EQ(d.gaps().size(), 1u);
  EffectParams p;
  p.gap_offset = 0.5;
  const auto a = SimulateEffects(d, kF, p, {}), b = SimulateEffects(d, kF, {}, {});
  // Before the gap: identical. After: shifted by a × the centroid displacement over the gap.
  EXPECT_LT(std::abs(a.poses[40].x - b.poses[40].x) + std::abs(a.poses[49].y - b.poses[49].y), 1e-15);
  auto centroid = [&](const EffectTrajectory& t, int f) {
    Vec2 c = Vec2::Zero();
    for (const auto& x : EffectPoints(d, t, f)) c += x;
    return Vec2(c / kNumPoints);
  };
  const Vec2 disp = centroid(b, 56) - centroid(b, 49);
  for (int f : {56, 80, 199}) EXPECT_LT((centroid(a, f) - centroid(b, f) - 0.5 * disp).norm(), 1e-12) << f;
  EXPECT_GT(disp.norm(), 1e-3);
}

}  // namespace
}  // namespace wormdrag::diagnose
