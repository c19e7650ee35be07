#include "core/estimate/grg.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

BatchObjective Pointwise(std::function<double(const std::vector<double>&)> f, int* calls = nullptr) {
  return [f, calls](const std::vector<std::vector<double>>& xs, std::vector<double>* out) {
    out->clear();
    for (const auto& x : xs) out->push_back(f(x));
    if (calls) ++*calls;
    return Status::Ok();
  };
}

TEST(Grg, MinimisesRosenbrock) {
  auto f = [](const std::vector<double>& x) { return 100 * std::pow(x[1] - x[0] * x[0], 2) + std::pow(1 - x[0], 2); };
  GrgOptions o;
  o.max_iterations = 500;
  o.gradient_tolerance = 1e-9;
  o.f_floor = 1e-12;
  auto r = MinimizeGrg({{0.2, 1.5}}, {-10, -10}, Pointwise(f), o);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->starts[0].x[0], 1.0, 1e-3);
  EXPECT_NEAR(r->starts[0].x[1], 1.0, 2e-3);
}

// Forward differences (n + 1 evaluations per gradient): the Gauss–Newton fit of the
// Rosenbrock residuals (10 (x1 − x0²), 1 − x0) still converges, with fewer evaluations
// per iteration than the central stencil.
TEST(Grg, ForwardDifferencesConverge) {
  ResidualObjective r = [](const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* out) {
    out->clear();
    for (const auto& x : xs) out->push_back({10 * (x[1] - x[0] * x[0]), 1 - x[0]});
    return Status::Ok();
  };
  GrgOptions o;
  o.max_iterations = 200;
  o.gradient_tolerance = 1e-10;
  o.f_floor = 1e-14;
  o.fd_step = 1e-6;
  o.forward_differences = true;
  auto fwd = MinimizeGrgLeastSquares({{-1.2, 1.0}}, {-10, -10}, r, o);
  ASSERT_TRUE(fwd.ok());
  EXPECT_NEAR(fwd->starts[0].x[0], 1.0, 1e-4);
  EXPECT_NEAR(fwd->starts[0].x[1], 1.0, 2e-4);
  o.forward_differences = false;
  auto cen = MinimizeGrgLeastSquares({{-1.2, 1.0}}, {-10, -10}, r, o);
  ASSERT_TRUE(cen.ok());
  EXPECT_LT(double(fwd->evaluations) / std::max(1, fwd->starts[0].iterations),
            double(cen->evaluations) / std::max(1, cen->starts[0].iterations));
}

// With the residuals' Jacobian given, an iterate costs one evaluation instead of the
// 2n + 1 of the central stencil, and the minimiser is the same.
TEST(Grg, ExactJacobiansReplaceTheStencil) {
  ResidualObjective r = [](const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* out) {
    out->clear();
    for (const auto& x : xs) out->push_back({10 * (x[1] - x[0] * x[0]), 1 - x[0]});
    return Status::Ok();
  };
  int jacobian_calls = 0;
  ResidualJacobianObjective rj = [&](const std::vector<std::vector<double>>& xs, std::vector<std::vector<double>>* out,
                                     std::vector<std::vector<double>>* jac) {
    ++jacobian_calls;
    out->clear();
    jac->clear();
    for (const auto& x : xs) {
      out->push_back({10 * (x[1] - x[0] * x[0]), 1 - x[0]});
      jac->push_back({-20 * x[0], -1, 10, 0});  // column-major: ∂r/∂x0, then ∂r/∂x1
    }
    return Status::Ok();
  };
  GrgOptions o;
  o.gradient_tolerance = 1e-10;
  o.f_floor = 1e-14;
  // Free, the minimum (1, 1); with x1 ≥ 0.5 the valley towards it crosses the bound
  // and both stop at the same constrained minimum, on the bound.
  for (double bound : {-10.0, 0.5}) {
    jacobian_calls = 0;
    auto fd = MinimizeGrgLeastSquares({{-1.2, 1.0}}, {-10, bound}, r, o);
    auto exact = MinimizeGrgLeastSquares({{-1.2, 1.0}}, {-10, bound}, r, o, rj);
    ASSERT_TRUE(fd.ok() && exact.ok());
    EXPECT_GT(jacobian_calls, 0);
    EXPECT_EQ(exact->jacobians, jacobian_calls);  // one start: one iterate per call
    if (bound < 0) {
      EXPECT_NEAR(exact->starts[0].x[0], 1.0, 1e-6);
      EXPECT_NEAR(exact->starts[0].x[1], 1.0, 1e-6);
    } else {
      EXPECT_EQ(exact->starts[0].x[1], 0.5);
      EXPECT_EQ(fd->starts[0].x[1], 0.5);
    }
    EXPECT_NEAR(exact->starts[0].x[0], fd->starts[0].x[0], 1e-6);
    EXPECT_LT(exact->evaluations, fd->evaluations);
  }
}

TEST(Grg, StopsAtAnActiveBound) {
  // Unconstrained minimum at (−1, 2); with x ≥ 0 the answer is (0, 2).
  auto f = [](const std::vector<double>& x) {
    return std::pow(x[0] + 1, 2) + std::pow(x[1] - 2, 2) + 0.5 * x[0] * x[1];
  };
  auto r = MinimizeGrg({{3, 3}}, {0, 0}, Pointwise(f), {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->starts[0].x[0], 0.0);  // exactly on the bound
  EXPECT_NEAR(r->starts[0].x[1], 2.0, 1e-4);
}

TEST(Grg, HoldsTheSumConstraint) {
  // min Σ w_i (x_i − c_i)² s.t. Σ x = Σ x0: Lagrange gives x_i = c_i + λ/(2 w_i).
  const std::vector<double> c = {1, 2, 3, 4}, w = {1, 2, 4, 8};
  auto f = [&](const std::vector<double>& x) {
    double s = 0;
    for (int i = 0; i < 4; ++i) s += w[i] * std::pow(x[i] - c[i], 2);
    return s;
  };
  GrgOptions o;
  o.fix_sum = true;
  o.gradient_tolerance = 1e-10;
  o.f_floor = 1e-12;
  const std::vector<double> x0 = {5, 5, 5, 5};  // Σ = 20, Σc = 10: λ = 10 / Σ 1/(2w)
  auto r = MinimizeGrg({x0}, {0, 0, 0, 0}, Pointwise(f), o);
  ASSERT_TRUE(r.ok());
  double inv = 0;
  for (double wi : w) inv += 1 / (2 * wi);
  const double lambda = 10 / inv;
  double sum = 0;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(r->starts[0].x[i], c[i] + lambda / (2 * w[i]), 1e-4) << i;
    sum += r->starts[0].x[i];
  }
  EXPECT_NEAR(sum, 20, 1e-9);
}

TEST(Grg, StartsShareBatchesAndDuplicatesMerge) {
  auto f = [](const std::vector<double>& x) { return std::pow(x[0] - 1, 2) + std::pow(x[1] - 1, 2); };
  int calls = 0;
  auto r = MinimizeGrg({{0, 0}, {2, 2}, {0.5, 1.5}}, {-5, -5}, Pointwise(f, &calls), {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(calls, r->rounds);
  for (const auto& s : r->starts) {
    if (s.termination == "merged") continue;
    EXPECT_NEAR(s.x[0], 1, 1e-4);
  }
  EXPECT_NEAR(r->starts[r->best].f, 0, 1e-8);
}

TEST(Grg, PropagatesEvaluationFailure) {
  auto fail = [](const std::vector<std::vector<double>>&, std::vector<double>*) {
    return Status::Unavailable("no workers");
  };
  auto r = MinimizeGrg({{1, 1}}, {0, 0}, fail, {});
  EXPECT_EQ(r.status().code(), Status::Code::kUnavailable);
}

}  // namespace
}  // namespace wormdrag
