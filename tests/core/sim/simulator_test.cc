#include "core/sim/simulator.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

// A recording made from the paper's pattern (Locomotion 2), sampled at `fps`.
Kinematics Recording(double fps, double duration, const Coefficients& c, Solver solver = Solver::kQuasiStatic) {
  SimOptions sim;
  sim.solver = solver;
  RecordingSpec spec;
  spec.fps = fps;
  spec.duration = duration;
  spec.substeps = 2;
  auto k = GenerateRecording(Locomotion(2), c, sim, spec);
  EXPECT_TRUE(k.ok()) << k.status().ToString();
  return *k;
}

ShapeDrive Drive(const Kinematics& k, int substeps = ShapeDriveOptions().substeps) {
  BodyModel body;
  body.length = k.BodyLength();
  auto d = ShapeDrive::Build(k, body, {substeps});
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return *d;
}

// Largest distance between corresponding points of two recordings, over all frames.
double MaxPointDistance(const Kinematics& a, const Kinematics& b) {
  double e = 0;
  for (size_t f = 0; f < a.frames.size(); ++f)
    for (int k = 0; k < kNumPoints; ++k) e = std::max(e, (a.frames[f].p[k] - b.frames[f].p[k]).norm());
  return e;
}

Kinematics Simulated(const Kinematics& k, const Coefficients& c, const SimOptions& opt,
                     int substeps = ShapeDriveOptions().substeps) {
  ShapeDrive d = Drive(k, substeps);
  Trajectory t = Simulator::Simulate(d, c, opt);
  EXPECT_TRUE(t.summary.ok()) << t.summary.OneLineReport();
  return TrajectoryToKinematics(d, t, k);
}

const Coefficients kF{0.62, 0.21, 0.0071, 0.0013};  // Coulomb and viscous both matter

SimOptions Opt(Solver s) {
  SimOptions o;
  o.solver = s;
  return o;
}

TEST(Simulator, WormMovesForward) {
  // Sanity: with normal friction above tangential, a backward-travelling wave
  // (ωt − k i: the wave runs head → tail) pushes the worm forward, head first.
  const Kinematics k = Recording(100, 3, kF);
  const Vec2 head0 = k.frames.front().p[0], head1 = k.frames.back().p[0];
  const Vec2 forward = k.frames.front().p[0] - k.frames.front().p[kNumLinks];
  EXPECT_GT((head1 - head0).dot(forward.normalized()), 0.05);
}

TEST(Simulator, RigidMotionOfInitialPoseMovesPathRigidly) {
  const Kinematics k = Recording(100, 2, kF);
  const double ang = 0.83;
  const Vec2 d(3.2, -1.7);
  Kinematics moved = k;
  const Eigen::Rotation2Dd R(ang);
  for (auto& f : moved.frames)
    for (auto& p : f.p) p = R * p + d;
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    Kinematics a = Simulated(k, kF, Opt(s)), b = Simulated(moved, kF, Opt(s));
    for (auto& f : a.frames)
      for (auto& p : f.p) p = R * p + d;
    EXPECT_LT(MaxPointDistance(a, b), 1e-9 * k.BodyLength()) << SolverName(s);
  }
}

TEST(Simulator, QuasiStaticPathIsScaleInvariant) {
  const Kinematics k = Recording(100, 5, kF);
  const Kinematics a = Simulated(k, kF, Opt(Solver::kQuasiStatic));
  for (double c : {0.01, 3.7, 250.0}) {
    const Kinematics b = Simulated(k, kF.Scaled(c), Opt(Solver::kQuasiStatic));
    EXPECT_LT(MaxPointDistance(a, b), 1e-9 * k.BodyLength()) << "factor " << c;
  }
}

TEST(Simulator, ForceAndMomentBalanceAtEveryQuasiStaticStep) {
  const Kinematics k = Recording(100, 3, kF);
  const ShapeDrive d = Drive(k);
  SimOptions o = Opt(Solver::kQuasiStatic);
  o.record_velocities = true;
  const Trajectory t = Simulator::Simulate(d, kF, o);
  ASSERT_EQ(t.knot_velocities.size(), d.knots().size());
  // Scale of the individual friction forces: each term is at most μ + η|v|.
  const double scale = kNumLinks * (kF.mu_n + kF.eta_n * 1.0);
  const double L = d.body().length;
  for (size_t j = 0; j < d.knots().size(); ++j) {
    const auto F = FrictionWrench(d.knots()[j], kF, o.epsilon, t.knot_velocities[j]);
    ASSERT_LT(std::abs(F[0]), 1e-8 * scale) << "knot " << j;
    ASSERT_LT(std::abs(F[1]), 1e-8 * scale) << "knot " << j;
    ASSERT_LT(std::abs(F[2]), 1e-8 * scale * L) << "knot " << j;
  }
}

// Error of a run with `substeps` against a fine reference, in body lengths.
double StepError(const Kinematics& k, const Coefficients& c, Solver s, int substeps, const Kinematics& ref) {
  return MaxPointDistance(Simulated(k, c, Opt(s), substeps), ref) / k.BodyLength();
}

// Smooth friction (viscous) shows the schemes' asymptotic orders; 25 fps makes the
// step error large enough to measure over 5 s.
const Coefficients kViscous{0, 0, 0.009, 0.002};

TEST(Simulator, QuasiStaticConvergesAtFourthOrder) {
  const Kinematics k = Recording(25, 5, kViscous);
  const Kinematics ref = Simulated(k, kViscous, Opt(Solver::kQuasiStatic), 64);
  const double e1 = StepError(k, kViscous, Solver::kQuasiStatic, 1, ref),
               e2 = StepError(k, kViscous, Solver::kQuasiStatic, 2, ref),
               e3 = StepError(k, kViscous, Solver::kQuasiStatic, 4, ref);
  std::printf("quasi-static step errors (BL): %.3g %.3g %.3g  orders %.2f %.2f\n", e1, e2, e3, std::log2(e1 / e2),
              std::log2(e2 / e3));
  EXPECT_GT(std::log2(e1 / e2), 3.3);
  EXPECT_GT(std::log2(e2 / e3), 3.3);
}

TEST(Simulator, InertialConverges) {
  const Kinematics k = Recording(25, 5, kViscous);
  const Kinematics ref = Simulated(k, kViscous, Opt(Solver::kInertial), 64);
  const double e1 = StepError(k, kViscous, Solver::kInertial, 1, ref),
               e2 = StepError(k, kViscous, Solver::kInertial, 2, ref),
               e3 = StepError(k, kViscous, Solver::kInertial, 4, ref);
  std::printf("inertial step errors (BL): %.3g %.3g %.3g  orders %.2f %.2f\n", e1, e2, e3, std::log2(e1 / e2),
              std::log2(e2 / e3));
  // Position quadrature is 4th order; the inertial correction (BDF2 in the stiff
  // regime) converges more slowly but is itself only ~1e-5 BL.
  EXPECT_GT(std::log2(e1 / e2), 2.0);
  EXPECT_GT(std::log2(e2 / e3), 1.5);
}

TEST(Simulator, CoulombFrictionConverges) {
  // Stick–slip switches make ξ(t) nearly jump; convergence is slower but steady.
  const Coefficients slipping{0.3, 0.5, 0.009, 0.002};
  const Kinematics k = Recording(300, 5, slipping);
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    const Kinematics ref = Simulated(k, slipping, Opt(s), 32);
    const double e1 = StepError(k, slipping, s, 2, ref), e2 = StepError(k, slipping, s, 4, ref),
                 e3 = StepError(k, slipping, s, 8, ref);
    std::printf("%s, stick-slip set: errors %.3g %.3g %.3g BL\n", SolverName(s), e1, e2, e3);
    EXPECT_LT(e2, e1);
    EXPECT_LT(e3, e2);
    EXPECT_LT(e3, 1e-5);
  }
}

TEST(Simulator, DefaultSettingsAreAccurateAt300Fps) {
  // Accuracy target: default settings within 1e-3 BL of a converged reference over
  // 5 s, and within 1e-4 BL with refinement (substeps 8).
  for (const Coefficients& c : {kF, Coefficients{0.3, 0.5, 0.009, 0.002}}) {
    const Kinematics k = Recording(300, 5, c);
    for (Solver s : {Solver::kInertial, Solver::kQuasiStatic}) {
      const Kinematics ref = Simulated(k, c, Opt(s), 32);
      const double e = StepError(k, c, s, ShapeDriveOptions().substeps, ref), e8 = StepError(k, c, s, 8, ref);
      std::printf("%s, %s at 300 fps: error %.3g BL (default), %.3g BL (substeps 8)\n", SolverName(s),
                  c.ToString().c_str(), e, e8);
      EXPECT_LT(e, 1e-3);
      EXPECT_LT(e8, 1e-4);
    }
  }
}

TEST(Simulator, InertialAgreesWithQuasiStaticAtPaperMass) {
  // Coulomb-dominated sets pin link velocities, and inertia then changes nothing
  // measurable: agreement far better than 1e-5 BL.
  const Kinematics k = Recording(300, 5, kF);
  for (const Coefficients& c : {kF, Coefficients{0.9, 0.1, 0.001, 0.008}, Coefficients{0.55, 0.15, 0.004, 0.006}}) {
    const double e = MaxPointDistance(Simulated(k, c, Opt(Solver::kInertial), 4),
                                      Simulated(k, c, Opt(Solver::kQuasiStatic), 4)) /
                     k.BodyLength();
    std::printf("inertial vs quasi-static for %s: %.3g BL\n", c.ToString().c_str(), e);
    EXPECT_LT(e, 1e-5) << c.ToString();
  }
}

TEST(Simulator, InertialLagScalesWithRelaxationTime) {
  // Where friction does not pin the body, the inertial path lags the quasi-static
  // one by ~ v·m/η: multiplying all coefficients by 4 must divide the gap by ~4
  // (the quasi-static path itself does not change, see the scale-invariance test).
  const Coefficients c{0.3, 0.5, 0.009, 0.002};
  const Kinematics k = Recording(300, 5, c);
  const Kinematics qs = Simulated(k, c, Opt(Solver::kQuasiStatic), 4);
  const double g1 = MaxPointDistance(Simulated(k, c, Opt(Solver::kInertial), 4), qs) / k.BodyLength();
  const double g4 = MaxPointDistance(Simulated(k, c.Scaled(4), Opt(Solver::kInertial), 4), qs) / k.BodyLength();
  std::printf("inertial lag: %.3g BL, with 4x friction %.3g BL (ratio %.2f)\n", g1, g4, g1 / g4);
  EXPECT_GT(g1 / g4, 3.0);
  EXPECT_LT(g1 / g4, 5.0);
  EXPECT_LT(g1, 1e-4);
}

TEST(Simulator, InertiaMattersWhenMassIsLarge) {
  // The converse check: the inertial solver is not silently quasi-static.
  const Coefficients c{0.3, 0.5, 0.009, 0.002};
  const Kinematics k = Recording(100, 2, c);
  ShapeDrive light = Drive(k);
  BodyModel heavy_body = light.body();
  heavy_body.link_mass = 1e-3;
  auto heavy = ShapeDrive::Build(k, heavy_body, {1});
  ASSERT_TRUE(heavy.ok());
  const Trajectory a = Simulator::Simulate(light, c, Opt(Solver::kInertial));
  const Trajectory b = Simulator::Simulate(*heavy, c, Opt(Solver::kInertial));
  double d = 0;
  for (size_t f = 0; f < a.poses.size(); ++f)
    d = std::max(d, std::hypot(a.poses[f].x - b.poses[f].x, a.poses[f].y - b.poses[f].y));
  EXPECT_GT(d, 1e-3);
}

TEST(Simulator, BodyThatDoesNotChangeShapeDoesNotMove) {
  Kinematics k;
  k.fps = 50;
  Shape q;
  for (int i = 0; i < kNumJoints; ++i) q[i] = 0.3 * std::sin(0.9 * i) + 0.05;
  const Points p = LabPoints({0.4, -0.2, 1.1}, q, 0.1);
  for (int f = 0; f < 100; ++f) {
    Frame fr;
    fr.t = f / k.fps;
    fr.valid = true;
    fr.p = p;
    fr.arc_length = 1.3;
    k.frames.push_back(fr);
  }
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    const Kinematics out = Simulated(k, kF, Opt(s));
    EXPECT_LT(MaxPointDistance(out, k), 1e-12) << SolverName(s);
  }
}

TEST(Simulator, SingularCoefficientsAreReported) {
  const Kinematics k = Recording(50, 1, kF);
  const ShapeDrive d = Drive(k);
  for (const Coefficients& c :
       {Coefficients{0, 0, 0, 0}, Coefficients{0.5, 0, 0.01, 0}, Coefficients{0, 0.5, 0, 0.01}}) {
    const Trajectory t = Simulator::Simulate(d, c, Opt(Solver::kQuasiStatic));
    EXPECT_FALSE(t.summary.singular.empty()) << c.ToString();
    EXPECT_FALSE(t.summary.ok());
    // With inertia the same sets are well posed.
    const Trajectory ti = Simulator::Simulate(d, c, Opt(Solver::kInertial));
    EXPECT_TRUE(ti.summary.ok()) << ti.summary.OneLineReport();
  }
}

TEST(Simulator, BatchLanesMatchSingleRuns) {
  const Kinematics k = Recording(100, 2, kF);
  const ShapeDrive d = Drive(k);
  // Six sets beside two idle lanes: each lane must match its set simulated alone.
  const Coefficients sets[6] = {kF,
                                {0.1, 0.9, 0.002, 0.004},
                                {0.5, 0.5, 0, 0.01},
                                {0.3, 0.5, 0.009, 0.002},
                                {0, 0, 0.009, 0.002},
                                {0.9, 0.1, 0.001, 0.008}};
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    SimWorkspace ws;
    Trajectory batch[6];
    Simulator::SimulateBatch(d, sets, 6, Opt(s), nullptr, ws, batch);
    for (int i = 0; i < 6; ++i) {
      const Trajectory single = Simulator::Simulate(d, sets[i], Opt(s));
      for (size_t f = 0; f < single.poses.size(); ++f) {
        // Bit for bit: a set's result must not depend on the sets sharing its batch
        // (the service chunks work differently from an embedded run).
        ASSERT_EQ(batch[i].poses[f].x, single.poses[f].x) << SolverName(s) << " set " << i << " frame " << f;
        ASSERT_EQ(batch[i].poses[f].q0, single.poses[f].q0);
      }
    }
  }
}

TEST(Simulator, AnUnconvergedLaneFailsAloneInItsBatch) {
  // On the bundled example (5 s at 300 fps, one knot per frame as Phases 1-2 run it)
  // the purely Coulomb set (0.2, 0.5, 0, 0) does not converge at a few knots: it must
  // be the only lane of its batch that fails.
  auto k = ReadKinematics(std::string(WORMDRAG_SOURCE_DIR) + "/examples/data/L2.csv");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  const ShapeDrive d = Drive(*k, 1);
  const Coefficients sets[4] = {{0.2, 0.4, 0.01, 0.01}, {0.2, 0.5, 0, 0}, kF, {0.2, 0.6, 0.002, 0}};
  SimWorkspace ws;
  Trajectory batch[4];
  Simulator::SimulateBatch(d, sets, 4, Opt(Solver::kInertial), nullptr, ws, batch);
  EXPECT_GT(batch[1].summary.unconverged, 0);
  EXPECT_FALSE(batch[1].summary.ok());
  for (int i : {0, 2, 3}) {
    EXPECT_TRUE(batch[i].summary.ok()) << "set " << i << ": " << batch[i].summary.OneLineReport();
    const Trajectory single = Simulator::Simulate(d, sets[i], Opt(Solver::kInertial));
    EXPECT_EQ(batch[i].summary.fallbacks, single.summary.fallbacks);
    EXPECT_EQ(batch[i].poses.back().x, single.poses.back().x);
  }
}

// Records the frames it sees and stops lane `victim` at frame `stop_at`, or every lane.
class StoppingObserver : public FrameObserver {
 public:
  StoppingObserver(const Trajectory* out, int victim, int stop_at) : out_(out), victim_(victim), stop_at_(stop_at) {}
  unsigned Frame(int frame_offset, unsigned live) override {
    frames.push_back(frame_offset);
    seen_x.push_back(out_[0].poses[frame_offset].x);  // lane 0 is never stopped alone
    if (frame_offset == stop_at_) live = victim_ < 0 ? 0u : live & ~(1u << victim_);
    return live;
  }
  std::vector<int> frames;
  std::vector<double> seen_x;

 private:
  const Trajectory* out_;
  int victim_, stop_at_;
};

TEST(Simulator, FrameObserverSeesEveryFrameAndStopsOnlyItsLanes) {
  const Kinematics k = Recording(100, 2, kF);
  const ShapeDrive d = Drive(k);
  const Coefficients sets[3] = {kF, {0.1, 0.9, 0.002, 0.004}, {0.5, 0.5, 0, 0.01}};
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    SimWorkspace ws, ws_plain;
    Trajectory watched[3], plain[3];
    Simulator::SimulateBatch(d, sets, 3, Opt(s), nullptr, ws_plain, plain);
    StoppingObserver obs(watched, 1, 50);
    Simulator::SimulateBatch(d, sets, 3, Opt(s), nullptr, ws, watched, &obs);
    // Every frame in order, each pose final when reported.
    ASSERT_EQ(obs.frames.size(), plain[0].poses.size());
    for (size_t f = 0; f < obs.frames.size(); ++f) {
      ASSERT_EQ(obs.frames[f], static_cast<int>(f));
      ASSERT_EQ(obs.seen_x[f], plain[0].poses[f].x) << "frame " << f;
    }
    // The stopped lane is marked; the others are bit for bit the unobserved run.
    EXPECT_TRUE(watched[1].summary.stopped);
    EXPECT_FALSE(watched[1].summary.ok());
    for (int i : {0, 2}) {
      EXPECT_FALSE(watched[i].summary.stopped);
      for (size_t f = 0; f < plain[i].poses.size(); ++f) {
        ASSERT_EQ(watched[i].poses[f].x, plain[i].poses[f].x) << SolverName(s) << " set " << i << " frame " << f;
        ASSERT_EQ(watched[i].poses[f].q0, plain[i].poses[f].q0);
      }
    }
    // Stopping every lane ends the batch: fewer knots solved than the drive has.
    StoppingObserver all(watched, -1, 20);
    Simulator::SimulateBatch(d, sets, 3, Opt(s), nullptr, ws, watched, &all);
    EXPECT_EQ(all.frames.back(), 20);
    EXPECT_LT(watched[0].summary.knots, static_cast<long>(d.knots().size()) / 2);
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(watched[i].summary.stopped);
  }
}

TEST(Simulator, NewtonIterationCounts) {
  // Not a timing test: the primal-dual method must stay far below the ~12
  // iterations per knot of plain Newton at ε = 1e-4, and never fall back.
  const Kinematics k = Recording(300, 5, kF);
  const ShapeDrive d = Drive(k);
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    const Trajectory t = Simulator::Simulate(d, kF, Opt(s));
    std::printf("%s: %s\n", SolverName(s), t.summary.OneLineReport().c_str());
    EXPECT_EQ(t.summary.fallbacks, 0);
    EXPECT_LT(double(t.summary.newton_iterations) / t.summary.knots, 8.0);
  }
}

}  // namespace
TEST(Simulator, SmallAndFullBatchesAgreeOnTheExamplePair) {
  // A batch of up to four sets runs on four lanes, a larger one on eight: on both worms
  // of the bundled example (with sets whose runs need the damped fallback, or fail),
  // a set's poses are the same bits in a batch of one, of three and of eight.
  const Coefficients sets[8] = {{0.606, 0.2347, 0.0062, 0.0019}, {0.5, 0.2, 0.0105, 0.0},   {0.5, 0.2, 0.01, 0.0005},
                                {0.61, 0.23, 0.0061, 0.0020},    {0.7, 0.25, 0.005, 0.001}, {0.2, 0.5, 0, 0},
                                {0.3, 0.2, 0.0, 0.002},          {0.02, 0.9, 0.0001, 0.0}};
  for (const char* name : {"L1.csv", "L2.csv"}) {
    auto k = ReadKinematics(std::string(WORMDRAG_SOURCE_DIR) + "/examples/data/" + name);
    ASSERT_TRUE(k.ok()) << k.status().ToString();
    const ShapeDrive d = Drive(*k);
    SimWorkspace ws;
    Trajectory eight[8], three[3];
    Simulator::SimulateBatch(d, sets, 8, Opt(Solver::kInertial), nullptr, ws, eight);
    Simulator::SimulateBatch(d, sets + 3, 3, Opt(Solver::kInertial), nullptr, ws, three);
    for (int i = 0; i < 8; ++i) {
      const Trajectory one = Simulator::Simulate(d, sets[i], Opt(Solver::kInertial));
      ASSERT_EQ(one.summary.ok(), eight[i].summary.ok()) << name << " set " << i;
      EXPECT_EQ(one.summary.fallbacks, eight[i].summary.fallbacks) << name << " set " << i;
      if (!one.summary.ok()) continue;
      for (size_t f = 0; f < one.poses.size(); ++f) {
        ASSERT_EQ(eight[i].poses[f].x, one.poses[f].x) << name << " set " << i << " frame " << f;
        ASSERT_EQ(eight[i].poses[f].q0, one.poses[f].q0) << name << " set " << i << " frame " << f;
        if (i >= 3 && i < 6) {
          ASSERT_EQ(three[i - 3].poses[f].y, one.poses[f].y) << name << " set " << i << " frame " << f;
        }
      }
    }
  }
}

}  // namespace wormdrag
