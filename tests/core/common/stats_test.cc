// Tests of the statistics utilities: the t distribution, its quantile and Welch's
// test against closed forms and published values.
#include "core/common/stats.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(Stats, IncompleteBetaClosedForms) {
  EXPECT_NEAR(RegularizedIncompleteBeta(2, 3, 0.5), 11.0 / 16, 1e-13);  // binomial sum
  EXPECT_NEAR(RegularizedIncompleteBeta(1, 1, 0.3), 0.3, 1e-13);        // uniform
  EXPECT_NEAR(RegularizedIncompleteBeta(1, 4, 0.2), 1 - std::pow(0.8, 4), 1e-13);
  EXPECT_NEAR(RegularizedIncompleteBeta(0.5, 0.5, 0.25), 2 / M_PI * std::asin(0.5), 1e-12);  // arcsine law
  for (double x : {0.05, 0.4, 0.77, 0.99})
    EXPECT_NEAR(RegularizedIncompleteBeta(3.5, 7.25, x), 1 - RegularizedIncompleteBeta(7.25, 3.5, 1 - x), 1e-13);
  EXPECT_EQ(RegularizedIncompleteBeta(2, 2, 0), 0);
  EXPECT_EQ(RegularizedIncompleteBeta(2, 2, 1), 1);
  EXPECT_TRUE(std::isnan(RegularizedIncompleteBeta(-1, 2, 0.5)));
  EXPECT_TRUE(std::isnan(RegularizedIncompleteBeta(1, 2, 1.5)));
}

TEST(Stats, StudentTCdfKnownValues) {
  for (double t : {-7.0, -1.3, 0.0, 0.4, 2.5, 30.0}) {
    EXPECT_NEAR(StudentTCdf(t, 1), 0.5 + std::atan(t) / M_PI, 1e-12) << t;             // Cauchy
    EXPECT_NEAR(StudentTCdf(t, 2), 0.5 + t / (2 * std::sqrt(2 + t * t)), 1e-12) << t;  // closed form, df 2
  }
  // Table values (two-sided 5 % and 1 % critical values).
  EXPECT_NEAR(StudentTCdf(2.228138852, 10), 0.975, 1e-9);
  EXPECT_NEAR(StudentTCdf(12.70620474, 1), 0.975, 1e-9);
  EXPECT_NEAR(StudentTCdf(2.045229642, 29), 0.975, 1e-9);
  EXPECT_NEAR(StudentTCdf(2.763262442, 28), 0.995, 1e-9);
  EXPECT_NEAR(StudentTCdf(-1.812461123, 10), 0.05, 1e-9);
  // Large df → normal: Φ(1.959963985) = 0.975.
  EXPECT_NEAR(StudentTCdf(1.959963985, 1e7), 0.975, 1e-6);
}

TEST(Stats, WelchTTestPublishedExample) {
  // The example of Wikipedia's "Welch's t-test" article (t = −2.46, ν ≈ 24.99, p = 0.021),
  // to more digits: t and ν from the sample moments, p by Simpson integration of the t
  // density (independent of the incomplete beta function).
  const std::vector<double> a = {27.5, 21.0, 19.0, 23.6, 17.0, 17.9, 16.9, 20.1,
                                 21.9, 22.6, 23.1, 19.6, 19.0, 21.7, 21.4};
  const std::vector<double> b = {27.1, 22.0, 20.8, 23.4, 23.4, 23.5, 25.8, 22.0,
                                 24.8, 20.2, 21.9, 22.1, 22.9, 20.5, 24.4};
  auto r = WelchTTest(a, b);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_NEAR(r->t, -2.455356398, 1e-8);
  EXPECT_NEAR(r->df, 24.98852929, 1e-6);
  EXPECT_NEAR(r->p_two_sided, 0.021378001, 1e-7);
  // Symmetric in the groups, and p from the t CDF.
  auto s = WelchTTest(b, a);
  ASSERT_TRUE(s.ok());
  EXPECT_NEAR(s->t, -r->t, 1e-12);
  EXPECT_NEAR(s->p_two_sided, r->p_two_sided, 1e-12);
  EXPECT_FALSE(WelchTTest({1.0}, {2.0, 3.0}).ok());
  EXPECT_FALSE(WelchTTest({1.0, 1.0}, {2.0, 2.0}).ok());
  EXPECT_FALSE(WelchTTest({1.0, NAN}, {2.0, 2.5}).ok());
}

TEST(Stats, WelchEqualVariancesEqualSizesMatchesStudent) {
  // Equal n and equal sd: Welch's df is 2(n−1) and t is Student's.
  const std::vector<double> a = {1, 2, 3, 4, 5}, b = {3, 4, 5, 6, 7};
  auto r = WelchTTest(a, b);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->df, 8, 1e-12);
  EXPECT_NEAR(r->t, -2 / std::sqrt(2.5 * 2 / 5), 1e-12);
  EXPECT_NEAR(r->p_two_sided, 2 * StudentTCdf(-2.0, 8), 1e-12);
}

TEST(Stats, StudentTQuantileKnownValues) {
  // Published two-sided 95 % / one-sided 95 % critical values.
  EXPECT_NEAR(StudentTQuantile(0.975, 1), 12.70620474, 1e-7);
  EXPECT_NEAR(StudentTQuantile(0.95, 2), 2.919985580, 1e-8);
  EXPECT_NEAR(StudentTQuantile(0.95, 4), 2.131846786, 1e-8);
  EXPECT_NEAR(StudentTQuantile(0.975, 10), 2.228138852, 1e-8);
  EXPECT_NEAR(StudentTQuantile(0.995, 28), 2.763262442, 1e-7);
  EXPECT_NEAR(StudentTQuantile(0.05, 10), -1.812461123, 1e-8);  // symmetric
  EXPECT_NEAR(StudentTQuantile(0.5, 3), 0, 1e-12);
  for (double p : {0.6, 0.9, 0.99, 0.9999}) EXPECT_NEAR(StudentTCdf(StudentTQuantile(p, 7.5), 7.5), p, 1e-12) << p;
  EXPECT_TRUE(std::isnan(StudentTQuantile(0, 3)));
  EXPECT_TRUE(std::isnan(StudentTQuantile(1, 3)));
  EXPECT_TRUE(std::isnan(StudentTQuantile(0.9, 0)));
}

TEST(Stats, PredictionBoundCoversANewDrawAtItsRate) {
  // For normal samples the one-sided Student-t prediction bound is exceeded by a new
  // draw with probability alpha exactly; measured over many samples of 3 and of 8.
  uint64_t state = 12345;
  auto uniform = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return ((state >> 11) + 0.5) / 9007199254740992.0;
  };
  auto normal = [&] { return std::sqrt(-2 * std::log(uniform())) * std::cos(2 * M_PI * uniform()); };
  for (int n : {3, 8}) {
    int above = 0;
    const int trials = 20000;
    for (int k = 0; k < trials; ++k) {
      std::vector<double> x(n);
      for (double& v : x) v = 5 + 2 * normal();
      if (5 + 2 * normal() > PredictionBound(x, 0.05)) ++above;
    }
    EXPECT_NEAR(above / static_cast<double>(trials), 0.05, 0.006) << n;
  }
  EXPECT_TRUE(std::isinf(PredictionBound({1.0}, 0.05)));
  EXPECT_DOUBLE_EQ(PredictionBound({2.0, 2.0, 2.0}, 0.05), 2.0);
}

// The p-value inverts the bound: a value at the (1 − α) bound has p-value α.
TEST(Stats, PredictionPValueInvertsTheBound) {
  const std::vector<double> x = {0.3, 1.1, 0.7, 2.0, 0.9};
  for (double alpha : {0.01, 0.05, 0.3, 0.8}) EXPECT_NEAR(PredictionPValue(x, PredictionBound(x, alpha)), alpha, 1e-9);
  EXPECT_NEAR(PredictionPValue(x, 1.0), 0.5, 1e-12);  // the mean
  EXPECT_TRUE(std::isnan(PredictionPValue({1.0}, 2.0)));
  EXPECT_TRUE(std::isnan(PredictionPValue({1.0, 1.0}, 2.0)));
}

}  // namespace
}  // namespace wormdrag
