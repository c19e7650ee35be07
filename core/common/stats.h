// Small statistics: Student's t distribution through the regularized incomplete beta
// function, its quantile, the prediction bound of a new draw from a sample (the
// diagnosis's noise-only null), and Welch's unequal-variance t-test (the paper's §4
// comparisons, Fig. 14). Written here (no statistics library), tested against closed
// forms and published values.
#pragma once

#include <vector>

#include "core/common/status.h"

namespace wormdrag {

// I_x(a, b), the regularized incomplete beta function, for a, b > 0 and 0 ≤ x ≤ 1
// (continued fraction, modified Lentz; relative accuracy ~1e-14). NaN outside the domain.
double RegularizedIncompleteBeta(double a, double b, double x);

// P(T ≤ t) for Student's t with `df` > 0 degrees of freedom (df need not be an integer).
double StudentTCdf(double t, double df);

// The t with P(T ≤ t) = p for Student's t with `df` > 0 degrees of freedom, 0 < p < 1
// (bisection on StudentTCdf to 1e-13 relative). NaN outside the domain.
double StudentTQuantile(double p, double df);

// The one-sided (1 − alpha) prediction bound of a new draw from the population of `x`:
// mean + t_{1−α, n−1} · sd · √(1 + 1/n). A new draw of a normal population lies above it
// with probability alpha exactly, whatever the population's mean and sd. +∞ for fewer
// than 2 values (no spread to judge by). 0 < alpha < 1.
double PredictionBound(const std::vector<double>& x, double alpha);
// The p-value of `value` as a new draw from the population of `x`, the alpha at which
// PredictionBound(x, alpha) = value: 1 − T_{n−1}((value − mean) / (sd · √(1 + 1/n))).
// NaN for fewer than 2 values or no spread.
double PredictionPValue(const std::vector<double>& x, double value);

struct SampleSummary {
  int n = 0;
  double mean = 0, sd = 0;  // sd with n − 1
};
SampleSummary Summarize(const std::vector<double>& x);

struct WelchResult {
  SampleSummary a, b;
  double t = 0;   // (mean_a − mean_b) / sqrt(s_a²/n_a + s_b²/n_b)
  double df = 0;  // Welch–Satterthwaite
  double p_two_sided = 1;
};

// Welch's t-test of equal means. Each group needs ≥ 2 finite values and the pooled
// standard error must be positive.
Result<WelchResult> WelchTTest(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace wormdrag
