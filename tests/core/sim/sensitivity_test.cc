// Forward sensitivities of the simulated poses (Simulator::SimulateBatchWithSensitivities)
// against finite differences of the plain simulation.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "core/sim/pattern.h"
#include "core/sim/simulator.h"

namespace wormdrag {
namespace {

ShapeDrive Drive(double fps, double duration, int substeps, double link_mass = kLinkMass) {
  SimOptions sim;
  RecordingSpec spec;
  spec.fps = fps;
  spec.duration = duration;
  auto k = GenerateRecording(Locomotion(2), {0.62, 0.21, 0.0071, 0.0013}, sim, spec);
  EXPECT_TRUE(k.ok()) << k.status().ToString();
  BodyModel body;
  body.length = k->BodyLength();
  body.link_mass = link_mass;
  auto d = ShapeDrive::Build(*k, body, {substeps});
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return *d;
}

// Tight Newton tolerance: the finite differences below divide the solver's error by
// the step, and the sensitivities are exact only at the converged velocities.
SimOptions Opt(Solver s) {
  SimOptions o;
  o.solver = s;
  o.velocity_tolerance = 1e-12;
  return o;
}

Trajectory Plain(const ShapeDrive& d, const Coefficients& c, const SimOptions& o) {
  Trajectory t = Simulator::Simulate(d, c, o);
  EXPECT_TRUE(t.summary.ok()) << c.ToString() << ": " << t.summary.OneLineReport();
  return t;
}

Trajectory WithSensitivities(const ShapeDrive& d, const Coefficients& c, const SimOptions& o) {
  SimWorkspace ws;
  Trajectory t;
  Simulator::SimulateBatchWithSensitivities(d, &c, 1, o, nullptr, ws, &t);
  EXPECT_TRUE(t.summary.ok()) << c.ToString() << ": " << t.summary.OneLineReport();
  EXPECT_EQ(t.sensitivities.size(), t.poses.size());
  return t;
}

double Component(const Pose& p, int r) {
  return r == 0 ? p.x : r == 1 ? p.y : p.q0;
}

// Grid steps (Δμ, Δμ, Δη, Δη): the units in which Phase 3 moves the coefficients.
const double kUnit[4] = {0.1, 0.1, 1e-3, 1e-3};

// Per pose component, the largest entry over the frames and coefficients of the
// sensitivity in grid units, Δ_k ∂g/∂c_k.
std::array<double, 3> Scales(const Trajectory& t) {
  std::array<double, 3> s{0, 0, 0};
  for (const auto& sf : t.sensitivities)
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 4; ++k) s[r] = std::max(s[r], kUnit[k] * std::abs(sf[r][k]));
  return s;
}

struct ColumnCheck {
  double size = 0;   // largest |Δ_k ∂g/∂c_k| relative to Scales (≤ 1)
  double error = 0;  // largest |Δ_k (FD − exact)| relative to Scales, at the best step
  double step = 0;   // that step, in grid units
};

// Coefficient k's column against finite differences of the plain simulation:
// second-order ones (central, or one-sided c, c + h, c + 2h at 0) at steps h and
// h/2, Richardson-extrapolated. Truncation error dominates large steps and roundoff
// small ones; where the path is nearly non-smooth (stick–slip) the best step is small,
// where a column is tiny it is large, so a ladder of steps is tried and the best
// kept: an incorrect derivative agrees at none.
ColumnCheck CheckColumn(const ShapeDrive& d, const Coefficients& c, const SimOptions& o, int k,
                        const Trajectory& exact) {
  const std::array<double, 3> scale = Scales(exact);
  ColumnCheck out;
  out.error = INFINITY;
  for (const auto& sf : exact.sensitivities)
    for (int r = 0; r < 3; ++r) out.size = std::max(out.size, kUnit[k] * std::abs(sf[r][k]) / scale[r]);
  const double ck = c.AsArray()[k];
  const bool at_zero = ck == 0;
  auto shifted = [&](double by) {
    auto a = c.AsArray();
    a[k] += by;
    return Plain(d, Coefficients::FromArray(a), o);
  };
  // Second-order difference quotient of every frame's pose components.
  auto quotient = [&](double h) {
    const Trajectory p = shifted(at_zero ? 2 * h : h), m = shifted(at_zero ? h : -h);
    std::vector<std::array<double, 3>> q(exact.poses.size());
    for (size_t f = 0; f < exact.poses.size(); ++f)
      for (int r = 0; r < 3; ++r) {
        const double a = Component(p.poses[f], r), b = Component(m.poses[f], r), z = Component(exact.poses[f], r);
        q[f][r] = at_zero ? (4 * b - 3 * z - a) / (2 * h) : (a - b) / (2 * h);
      }
    return q;
  };
  for (double step : {1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6}) {
    const double h = step * kUnit[k];
    if (!at_zero && h >= ck) continue;
    const auto q1 = quotient(h), q2 = quotient(h / 2);
    double err = 0;
    for (size_t f = 0; f < exact.poses.size(); ++f)
      for (int r = 0; r < 3; ++r) {
        const double fd = (4 * q2[f][r] - q1[f][r]) / 3;
        err = std::max(err, kUnit[k] * std::abs(fd - exact.sensitivities[f][r][k]) / scale[r]);
      }
    if (err < out.error) {
      out.error = err;
      out.step = step;
    }
  }
  return out;
}

struct Case {
  const char* name;
  Coefficients c;
};
const Case kCases[] = {
    {"Coulomb-dominated", {0.9, 0.1, 0.001, 0.008}},
    {"mixed", {0.62, 0.21, 0.0071, 0.0013}},
    {"slipping", {0.3, 0.5, 0.009, 0.002}},
    {"viscous (mu = 0)", {0, 0, 0.009, 0.002}},
    {"no normal viscosity (eta_n = 0)", {0.5, 0.2, 0, 0.004}},
};

// Both solvers, and the inertial one with a body 2600× heavier than the paper's, where
// inertia and so the momentum history's sensitivities dominate.
TEST(Sensitivity, AgreesWithFiniteDifferences) {
  const ShapeDrive paper = Drive(100, 2, 2), heavy = Drive(100, 2, 2, 1e-3);
  struct Model {
    const char* name;
    const ShapeDrive* drive;
    Solver solver;
  };
  for (const Model& md :
       {Model{"quasi-static", &paper, Solver::kQuasiStatic}, Model{"inertial", &paper, Solver::kInertial},
        Model{"inertial, heavy", &heavy, Solver::kInertial}}) {
    const SimOptions o = Opt(md.solver);
    for (const Case& cs : kCases) {
      const Trajectory t = WithSensitivities(*md.drive, cs.c, o);
      for (int k = 0; k < 4; ++k) {
        const ColumnCheck col = CheckColumn(*md.drive, cs.c, o, k, t);
        std::printf("%-16s %-32s coefficient %d: column %.2g, error %.2g (%.2g of the column) at step %g\n", md.name,
                    cs.name, k, col.size, col.error, col.error / col.size, col.step);
        // Within 1e-5 of the column; a column below 1e-3 of the Jacobian (η_n where
        // Coulomb friction pins the normal velocities: ~3e-6) is below what finite
        // differences resolve in double precision, and is checked to 1e-8 of the
        // Jacobian instead.
        EXPECT_LT(col.error, 1e-5 * std::max(col.size, 1e-3)) << md.name << ", " << cs.name << ", coefficient " << k;
      }
    }
  }
}

TEST(Sensitivity, PosesAreThoseOfThePlainRun) {
  const ShapeDrive d = Drive(100, 1, 2);
  // Six sets (8 lanes); each alone runs on the narrower kernel.
  const Coefficients sets[6] = {{0.62, 0.21, 0.0071, 0.0013}, {0, 0, 0.009, 0.002},     {0.3, 0.5, 0.009, 0.002},
                                {0.5, 0.2, 0, 0.004},         {0.9, 0.1, 0.001, 0.008}, {0.1, 0.9, 0.002, 0.004}};
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    SimWorkspace ws;
    Trajectory plain[6], sens[6];
    Simulator::SimulateBatch(d, sets, 6, Opt(s), nullptr, ws, plain);
    Simulator::SimulateBatchWithSensitivities(d, sets, 6, Opt(s), nullptr, ws, sens);
    for (int i = 0; i < 6; ++i) {
      EXPECT_TRUE(plain[i].sensitivities.empty());
      for (size_t f = 0; f < plain[i].poses.size(); ++f) {
        ASSERT_EQ(plain[i].poses[f].x, sens[i].poses[f].x) << SolverName(s) << " set " << i << " frame " << f;
        ASSERT_EQ(plain[i].poses[f].q0, sens[i].poses[f].q0);
      }
      // A set's sensitivities do not depend on the sets sharing its batch.
      const Trajectory single = WithSensitivities(d, sets[i], Opt(s));
      for (size_t f = 0; f < single.poses.size(); ++f) ASSERT_EQ(single.sensitivities[f], sens[i].sensitivities[f]);
    }
  }
}

TEST(Sensitivity, QuasiStaticPathHasNoScaleDirection) {
  // Without inertia the path is unchanged by scaling all four coefficients (degree-0
  // homogeneous), so Σ_k c_k ∂g/∂c_k = 0 exactly; with inertia it is not.
  const ShapeDrive d = Drive(100, 2, 2);
  const Coefficients c{0.3, 0.5, 0.009, 0.002};
  const auto a = c.AsArray();
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    const Trajectory t = WithSensitivities(d, c, Opt(s));
    double along = 0, scale = 0;
    for (const auto& sf : t.sensitivities)
      for (int r = 0; r < 2; ++r) {
        double dot = 0;
        for (int k = 0; k < 4; ++k) {
          dot += a[k] * sf[r][k];
          scale = std::max(scale, std::abs(a[k] * sf[r][k]));
        }
        along = std::max(along, std::abs(dot));
      }
    std::printf("%s: scale direction %.3g of %.3g\n", SolverName(s), along, scale);
    if (s == Solver::kQuasiStatic)
      EXPECT_LT(along, 1e-9 * scale);
    else
      EXPECT_GT(along, 1e-7 * scale);
  }
}

TEST(Sensitivity, ResetFramesRestartFromZero) {
  const ShapeDrive d = Drive(100, 1, 2);
  const Coefficients c{0.62, 0.21, 0.0071, 0.0013};
  PoseResets resets;
  resets.frames = {40};
  SimWorkspace ws;
  Trajectory t;
  Simulator::SimulateBatchWithSensitivities(d, &c, 1, Opt(Solver::kInertial), &resets, ws, &t);
  for (int k = 0; k < 4; ++k) {
    EXPECT_NE(t.sensitivities[39][0][k], 0.0);
    EXPECT_EQ(t.sensitivities[40][0][k], 0.0);
    EXPECT_NE(t.sensitivities[41][0][k], 0.0);
  }
}

}  // namespace
}  // namespace wormdrag
