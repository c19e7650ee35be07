// The lane functions of a pair (worm by worm, combined): the residual Jacobian against
// finite differences of the residuals, and the same bits whether a batch's worms run on
// one thread or two (LocalEvaluator).
#include "core/estimate/paired_path.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

std::shared_ptr<const PairedPath> Pair(const Coefficients& truth, Solver solver) {
  EvaluationOptions e;
  e.t_max = 1;
  e.sim.solver = solver;
  e.sim.velocity_tolerance = 1e-12;  // finite differences divide the solver's error by the step
  std::array<Kinematics, 2> k;
  for (int j = 0; j < 2; ++j) {
    RecordingSpec spec;
    spec.fps = 100;
    spec.duration = 1;
    auto r = GenerateRecording(Locomotion(j + 1), truth, SimOptions(), spec);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    k[j] = *r;
  }
  // A gap, so that the scored frames skip some and (with the restart) the pose resets.
  for (int f = 40; f < 44; ++f) k[1].frames[f].valid = false;
  e.restart_after_gaps = true;
  auto p = PairedPath::Create(k, {"L1", "L2"}, e);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return *p;
}

TEST(ResidualJacobian, AgreesWithFiniteDifferencesOfTheResiduals) {
  const Coefficients truth{0.55, 0.25, 0.006, 0.003};
  const Coefficients at{0.6, 0.2, 0.005, 0.0035};  // away from the truth: residuals are not small
  const double unit[4] = {0.1, 0.1, 1e-3, 1e-3};
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    auto pair = Pair(truth, s);
    LocalEvaluator ev(pair, 2);
    std::vector<std::vector<double>> r, jac, r_plain;
    ASSERT_TRUE(ev.EvaluateResidualJacobians({at}, &r, &jac).ok());
    ASSERT_TRUE(ev.EvaluateResiduals({at}, &r_plain).ok());
    const size_t m = r[0].size();
    ASSERT_EQ(m, 2u * pair->scored_count());
    ASSERT_EQ(jac[0].size(), 4 * m);
    EXPECT_EQ(r[0], r_plain[0]);  // bit for bit: line searches compare them
    // Central differences at 1e-4 grid steps, Richardson-extrapolated.
    std::vector<Coefficients> stencil;
    for (int k = 0; k < 4; ++k)
      for (double h : {1e-4, -1e-4, 5e-5, -5e-5}) {
        auto a = at.AsArray();
        a[k] += h * unit[k];
        stencil.push_back(Coefficients::FromArray(a));
      }
    std::vector<std::vector<double>> rs;
    ASSERT_TRUE(ev.EvaluateResiduals(stencil, &rs).ok());
    double top = 0;
    for (int k = 0; k < 4; ++k)
      for (size_t q = 0; q < m; ++q) top = std::max(top, unit[k] * std::abs(jac[0][k * m + q]));
    for (int k = 0; k < 4; ++k) {
      double err = 0;
      for (size_t q = 0; q < m; ++q) {
        const double d1 = (rs[4 * k][q] - rs[4 * k + 1][q]) / (2e-4 * unit[k]);
        const double d2 = (rs[4 * k + 2][q] - rs[4 * k + 3][q]) / (1e-4 * unit[k]);
        err = std::max(err, unit[k] * std::abs((4 * d2 - d1) / 3 - jac[0][k * m + q]));
      }
      std::printf("%s, coefficient %d: error %.2g of the largest entry\n", SolverName(s), k, err / top);
      EXPECT_LT(err, 1e-6 * top) << SolverName(s) << ", coefficient " << k;
    }
  }
}

// A set's residuals and Jacobian do not depend on the sets sharing its batch or on
// what the evaluator's workspaces computed before (a restarted run gets the same).
TEST(ResidualJacobian, IndependentOfBatchAndHistory) {
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    auto pair = Pair({0.55, 0.25, 0.006, 0.003}, s);
    const Coefficients a{0.6, 0.2, 0.005, 0.0035};
    LocalEvaluator fresh(pair, 1), used(pair, 2);
    std::vector<std::vector<double>> r1, j1, r2, j2, scratch;
    ASSERT_TRUE(fresh.EvaluateResidualJacobians({a}, &r1, &j1).ok());
    std::vector<Coefficients> others;
    for (int i = 0; i < 11; ++i) others.push_back({0.1 + 0.07 * i, 0.3, 0.001 * i, 0.002});
    ASSERT_TRUE(used.Evaluate(others, &scratch.emplace_back()).ok());
    ASSERT_TRUE(used.EvaluateResidualJacobians(others, &scratch, &j2).ok());
    others.push_back(a);
    ASSERT_TRUE(used.EvaluateResidualJacobians(others, &r2, &j2).ok());
    EXPECT_EQ(r1[0], r2.back()) << SolverName(s);
    EXPECT_EQ(j1[0], j2.back()) << SolverName(s);
  }
}

TEST(ResidualJacobian, UnsimulableSetHasNone) {
  auto pair = Pair({0.55, 0.25, 0.006, 0.003}, Solver::kQuasiStatic);
  LocalEvaluator ev(pair, 1);
  std::vector<std::vector<double>> r, jac;
  ASSERT_TRUE(ev.EvaluateResidualJacobians({{0, 0, 0, 0}, {0.5, 0.2, 0.004, 0.002}}, &r, &jac).ok());
  EXPECT_TRUE(r[0].empty());
  EXPECT_TRUE(jac[0].empty());
  EXPECT_EQ(jac[1].size(), 4 * r[1].size());
}

// A batch smaller than one chunk of kLanes sets per thread runs its two worms on two
// threads; every output must be the bits one thread computes, failed sets included.
TEST(WormLanes, SplitBatchesGiveTheBitsOfOneThread) {
  std::vector<Coefficients> pool = {{0, 0, 0, 0}};  // the quasi-static solver cannot simulate it
  for (int i = 0; i < 16; ++i) pool.push_back({0.3 + 0.05 * i, 0.15 + 0.01 * i, 0.004 + 3e-4 * i, 0.002});
  for (Solver s : {Solver::kQuasiStatic, Solver::kInertial}) {
    auto pair = Pair({0.55, 0.25, 0.006, 0.003}, s);
    LocalEvaluator one(pair, 1);
    for (int threads : {2, 3, 5}) {
      LocalEvaluator many(pair, threads);
      for (size_t n : {1, 2, 8, 9, 17}) {
        const std::vector<Coefficients> sets(pool.begin(), pool.begin() + n);
        for (Objective o : {Objective::kMeanDistance, Objective::kMeanSquaredDistance}) {
          KnotCount k1, k2;
          EvaluationRequest req;
          req.objective = o;
          req.knots = &k1;
          std::vector<double> e1, e2;
          ASSERT_TRUE(one.Evaluate(sets, &e1, req).ok());
          req.knots = &k2;
          ASSERT_TRUE(many.Evaluate(sets, &e2, req).ok());
          EXPECT_EQ(e1, e2) << SolverName(s) << ", " << threads << " threads, " << n << " sets";
          if (s == Solver::kQuasiStatic) { EXPECT_TRUE(std::isinf(e2[0])); }
          EXPECT_EQ(k1.simulated.load(), k2.simulated.load());
          EXPECT_EQ(k1.full.load(), k2.full.load());
        }
        std::vector<std::vector<double>> r1, r2, j1, j2, p1, p2;
        ASSERT_TRUE(one.EvaluateResiduals(sets, &p1).ok());
        ASSERT_TRUE(many.EvaluateResiduals(sets, &p2).ok());
        ASSERT_TRUE(one.EvaluateResidualJacobians(sets, &r1, &j1).ok());
        ASSERT_TRUE(many.EvaluateResidualJacobians(sets, &r2, &j2).ok());
        EXPECT_EQ(p1, p2) << SolverName(s) << ", " << threads << " threads, " << n << " sets";
        EXPECT_EQ(r1, r2) << SolverName(s) << ", " << threads << " threads, " << n << " sets";
        EXPECT_EQ(j1, j2) << SolverName(s) << ", " << threads << " threads, " << n << " sets";
        EXPECT_EQ(p2, r2);
        if (s == Solver::kQuasiStatic) { EXPECT_TRUE(r2[0].empty() && j2[0].empty()); }
      }
    }
  }
}

}  // namespace
}  // namespace wormdrag
