// Small statistics for the paper's §4 comparisons (Fig. 14): Student's t
// distribution through the regularized incomplete beta function, and Welch's
// unequal-variance t-test. Written here (no statistics library), tested against
// closed forms and published values.
#pragma once

#include <vector>

#include "core/common/status.h"

namespace wormdrag {

// I_x(a, b), the regularized incomplete beta function, for a, b > 0 and 0 ≤ x ≤ 1
// (continued fraction, modified Lentz; relative accuracy ~1e-14). NaN outside the domain.
double RegularizedIncompleteBeta(double a, double b, double x);

// P(T ≤ t) for Student's t with `df` > 0 degrees of freedom (df need not be an integer).
double StudentTCdf(double t, double df);

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
