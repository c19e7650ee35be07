#include "core/estimate/bootstrap.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "core/filter/shape_smoothing.h"
#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

const Coefficients kTruth{0.55, 0.25, 0.006, 0.003};

Kinematics Loco(int index) {
  RecordingSpec spec;
  spec.fps = 300;
  spec.duration = 2;
  spec.substeps = EvaluationOptions().SubstepsFor(spec.fps);
  spec.as_estimated = true;
  auto k = GenerateRecording(Locomotion(index), kTruth, SimOptions(), spec);
  EXPECT_TRUE(k.ok());
  return *k;
}

std::shared_ptr<const PairedPath> Pair(Kinematics a, Kinematics b) {
  EvaluationOptions e;
  e.t_max = 2;
  auto p = PairedPath::Create({std::move(a), std::move(b)}, {"L1", "L2"}, e);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return *p;
}

TEST(Bootstrap, ReplicateWithoutNoiseIsTheFittedModelsPath) {
  const auto pair = Pair(Loco(1), Loco(2));
  auto rep = MakeReplicate(*pair, kTruth, {0, 0}, 7);
  ASSERT_TRUE(rep.ok()) << rep.status().ToString();
  // The recordings were simulated with the same model: the replicate reproduces them.
  for (int j = 0; j < 2; ++j) {
    const Kinematics& k = pair->worm(j).kinematics;
    ASSERT_EQ((*rep)[j].frames.size(), k.frames.size());
    double worst = 0;
    for (size_t f = 0; f < k.frames.size(); ++f)
      for (int p = 0; p < kNumPoints; ++p)
        worst = std::max(worst, ((*rep)[j].frames[f].p[p] - k.frames[f].p[p]).norm());
    EXPECT_LT(worst / pair->worm(j).body_length(), 1e-6);
  }
}

TEST(Bootstrap, ReplicateCarriesTheGivenNoiseReproducibly) {
  Kinematics a = Loco(1);
  for (int f = 100; f < 110; ++f) a.frames[f].valid = false;
  const auto pair = Pair(a, Loco(2));
  const double sigma = 0.004;
  auto r1 = MakeReplicate(*pair, kTruth, {sigma, 2 * sigma}, 7);
  auto r2 = MakeReplicate(*pair, kTruth, {sigma, 2 * sigma}, 7);
  auto r3 = MakeReplicate(*pair, kTruth, {sigma, 2 * sigma}, 8);
  ASSERT_TRUE(r1.ok() && r2.ok() && r3.ok());
  EXPECT_EQ((*r1)[0].frames[5].p[3], (*r2)[0].frames[5].p[3]);
  EXPECT_NE((*r1)[0].frames[5].p[3], (*r3)[0].frames[5].p[3]);
  for (int f = 100; f < 110; ++f) EXPECT_FALSE((*r1)[0].frames[f].valid);
  // Resampling by arc length moves points along the body: what remains is about the
  // given SD, as the recording's own estimate sees it.
  EXPECT_NEAR(TrackingNoiseByDifferences((*r1)[0]), sigma, 0.2 * sigma);
  EXPECT_NEAR(TrackingNoiseByDifferences((*r1)[1]), 2 * sigma, 0.4 * sigma);
}

std::vector<Coefficients> Refits(double k_mu_shift, double sd, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, sd);
  std::vector<Coefficients> fits;
  for (int i = 0; i < n; ++i) {
    Coefficients c = kTruth;
    c.mu_n = kTruth.mu_n * k_mu_shift * std::exp(g(rng));
    fits.push_back(c);
  }
  return fits;
}

TEST(Bootstrap, BasicIntervalCorrectsTheRefitsShift) {
  BootstrapOptions o;
  const auto fits = Refits(1.2, 0.02, 40, 1);  // refits 20 % above the fit: the estimator's bias
  const BootstrapReport r = SummariseBootstrap(kTruth, fits, std::vector<bool>(fits.size(), true), 0.1, 1e-3, o);
  EXPECT_EQ(r.replicates, 40);
  ASSERT_TRUE(r.K_mu.determined) << r.K_mu.why;
  // The interval lies below the fit, around fit / 1.2.
  EXPECT_LT(r.K_mu.hi, kTruth.K_mu());
  EXPECT_NEAR(std::sqrt(r.K_mu.lo * r.K_mu.hi), kTruth.K_mu() / 1.2, 0.03 * kTruth.K_mu());
  // The value reported is the fit with that bias taken out.
  EXPECT_NEAR(r.K_mu.corrected, kTruth.K_mu() / 1.2, 0.03 * kTruth.K_mu());
  EXPECT_DOUBLE_EQ(r.K_mu.estimate, kTruth.K_mu());
  EXPECT_TRUE(r.K_eta.determined);  // the refits leave it exactly in place
  EXPECT_DOUBLE_EQ(r.K_eta.lo, kTruth.K_eta());
}

// When the refits scatter about the fit as the fit scatters about the truth (bias
// included), the basic interval holds the truth as often as its level says, with 20
// refits and whatever the shape of the scatter. Quantiles at the usual positions
// q (n − 1) + 1 would hold it 81 % of the time.
TEST(Bootstrap, IntervalsHoldTheTruthAsOftenAsTheirLevelSays) {
  BootstrapOptions o;
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0, 0.05);
  std::exponential_distribution<double> skewed(20);  // mean 0.05, skewness 2
  const std::vector<bool> ok(o.replicates, true);
  for (int shape = 0; shape < 2; ++shape) {
    auto draw = [&] { return shape == 0 ? normal(rng) : skewed(rng) - 0.05; };
    const int trials = 4000;
    int held = 0;
    for (int t = 0; t < trials; ++t) {
      const double bias = 0.1;  // in log K_μ, shared by the fit and its refits
      Coefficients fit = kTruth;
      fit.mu_n = kTruth.mu_n * std::exp(bias + draw());
      std::vector<Coefficients> refits(o.replicates, fit);
      for (Coefficients& c : refits) c.mu_n = fit.mu_n * std::exp(bias + draw());
      const BootstrapReport r = SummariseBootstrap(fit, refits, ok, 0.1, 1e-3, o);
      held += r.K_mu.lo <= kTruth.K_mu() && kTruth.K_mu() <= r.K_mu.hi;
    }
    // Binomial SD at 4000 trials: 0.5 %.
    EXPECT_NEAR(static_cast<double>(held) / trials, o.level, 0.02) << (shape == 0 ? "normal" : "skewed");
  }
}

TEST(Bootstrap, ReplicateNoiseAboveTheDatasDoesNotShiftTheInterval) {
  // Clean data, replicates at the noise floor: their shift is the floor's, not the
  // data's, so the interval keeps the fit inside and only takes the refits' spread.
  BootstrapOptions o;
  const auto fits = Refits(0.9, 0.02, 40, 5);
  const BootstrapReport r = SummariseBootstrap(kTruth, fits, std::vector<bool>(fits.size(), true), 0.1, 1e-3, o,
                                               /*bias_share=*/0);
  ASSERT_TRUE(r.K_mu.determined);
  EXPECT_LT(r.K_mu.lo, kTruth.K_mu());
  EXPECT_GT(r.K_mu.hi, kTruth.K_mu());
  EXPECT_LT(r.K_mu.hi / r.K_mu.lo, 1.2);
}

TEST(Bootstrap, WideOrBoundedIntervalsAreNotDetermined) {
  BootstrapOptions o;
  auto wide = Refits(1.0, 0.6, 40, 2);
  BootstrapReport r = SummariseBootstrap(kTruth, wide, std::vector<bool>(wide.size(), true), 0.1, 1e-3, o);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_NE(r.K_mu.why.find("spans a factor"), std::string::npos) << r.K_mu.why;

  auto bounded = Refits(1.0, 0.01, 40, 3);
  for (int i = 0; i < 10; ++i) bounded[i].mu_t = 0;  // a quarter of the refits lose μ_t
  r = SummariseBootstrap(kTruth, bounded, std::vector<bool>(bounded.size(), true), 0.1, 1e-3, o);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_NE(r.K_mu.why.find("bound"), std::string::npos) << r.K_mu.why;
  EXPECT_FALSE(r.v_c.determined);

  // Most refits lose μ_t: the median is infinite, and the interval reaches both bounds
  // rather than having an undefined end.
  for (int i = 0; i < 30; ++i) bounded[i].mu_t = 0;
  r = SummariseBootstrap(kTruth, bounded, std::vector<bool>(bounded.size(), true), 0.1, 1e-3, o);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_EQ(r.K_mu.lo, 0);
  EXPECT_EQ(r.K_mu.hi, std::numeric_limits<double>::infinity());

  Coefficients viscous{0, 0, 0.003, 0.002};
  std::vector<Coefficients> same(20, viscous);
  r = SummariseBootstrap(viscous, same, std::vector<bool>(20, true), 0.1, 1e-3, o);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_NE(r.K_mu.why.find("undefined"), std::string::npos);
  EXPECT_TRUE(r.K_eta.determined);
  const std::string text = r.ToText();
  EXPECT_EQ(text.find("nan"), std::string::npos) << text;
}

TEST(Bootstrap, RefitsThatIgnoreTheirDataOrANegligiblePartAreNotDetermined) {
  BootstrapOptions o;
  // Every refit at one scale, half the fit's: nothing in the data moved them.
  std::vector<Coefficients> halved(20, kTruth);
  for (Coefficients& c : halved) c = {c.mu_n / 2, c.mu_t / 2, c.eta_n / 2, c.eta_t / 2};
  BootstrapReport r = SummariseBootstrap(kTruth, halved, std::vector<bool>(20, true), 0.1, 1e-3, o);
  EXPECT_FALSE(r.scale.determined);
  EXPECT_NE(r.scale.why.find("do not move"), std::string::npos) << r.scale.why;
  EXPECT_TRUE(r.K_mu.determined);  // ratios unchanged: exactly in place

  // A trace of Coulomb friction on a viscous body (v_c 0.01 mm/s at 0.5 mm/s):
  // its ratio has an interval, but no path constrains it.
  const Coefficients water{0.002, 0.00002, 0.003, 0.002};
  auto fits = Refits(1.0, 0.02, 20, 9);
  for (Coefficients& c : fits) c = {water.mu_n * c.mu_n / kTruth.mu_n, water.mu_t, water.eta_n, water.eta_t};
  r = SummariseBootstrap(water, fits, std::vector<bool>(20, true), 0.1, 1e-3, o, 1.0, /*link_speed=*/0.5);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_NE(r.K_mu.why.find("Coulomb friction is only"), std::string::npos) << r.K_mu.why;
  EXPECT_FALSE(r.v_c.determined);
  EXPECT_TRUE(r.K_eta.determined);
  // Without the speed the rule is not applied.
  r = SummariseBootstrap(water, fits, std::vector<bool>(20, true), 0.1, 1e-3, o, 1.0, 0);
  EXPECT_TRUE(r.K_mu.determined);
}

TEST(Bootstrap, RatiosOfAMixedLawNeedItsCrossoverSpeed) {
  BootstrapOptions o;
  // v_c 0.5 mm/s at links moving 0.5 mm/s: each part carries half the drag.
  const Coefficients mixed{0.006, 0.0015, 0.006, 0.003};
  std::mt19937 rng(4);
  std::normal_distribution<double> g(0, 1);
  auto refits = [&](double v_c_sd) {
    std::vector<Coefficients> fits;
    for (int i = 0; i < 20; ++i) {
      const double k = std::exp(0.02 * g(rng)), v = std::exp(v_c_sd * g(rng));
      fits.push_back({mixed.mu_n * k * v, mixed.mu_t * v, mixed.eta_n, mixed.eta_t});
    }
    return fits;
  };
  // Tight ratios, v_c spread over a factor of several: the ratios are withheld.
  auto loose = refits(0.6);
  BootstrapReport r = SummariseBootstrap(mixed, loose, std::vector<bool>(20, true), 0.1, 1e-3, o, 1.0, 0.5);
  EXPECT_FALSE(r.v_c.determined);
  EXPECT_FALSE(r.K_mu.determined);
  EXPECT_FALSE(r.K_eta.determined);
  EXPECT_NE(r.K_mu.why.find("crossover speed"), std::string::npos) << r.K_mu.why;
  EXPECT_LT(r.K_mu.hi / r.K_mu.lo, 1.2);  // its interval alone would have passed
  // v_c determined too: all three stand.
  auto tight = refits(0.02);
  r = SummariseBootstrap(mixed, tight, std::vector<bool>(20, true), 0.1, 1e-3, o, 1.0, 0.5);
  EXPECT_TRUE(r.v_c.determined) << r.v_c.why;
  EXPECT_TRUE(r.K_mu.determined) << r.K_mu.why;
  EXPECT_TRUE(r.K_eta.determined) << r.K_eta.why;
  // A Coulomb-dominated law (v_c 500 mm/s) keeps its K_μ whatever v_c does.
  const Coefficients agar{0.6, 0.2, 0.0012, 0.0004};
  std::vector<Coefficients> agar_fits;
  for (int i = 0; i < 20; ++i) {
    const double k = std::exp(0.02 * g(rng)), v = std::exp(0.6 * g(rng));
    agar_fits.push_back({agar.mu_n * k, agar.mu_t, agar.eta_n * v, agar.eta_t * v});
  }
  r = SummariseBootstrap(agar, agar_fits, std::vector<bool>(20, true), 0.1, 1e-3, o, 1.0, 0.5);
  EXPECT_TRUE(r.K_mu.determined) << r.K_mu.why;
}

TEST(Bootstrap, FailedReplicatesAreCountedNotUsed) {
  BootstrapOptions o;
  auto fits = Refits(1.0, 0.02, 20, 4);
  std::vector<bool> ok(20, true);
  ok[3] = ok[9] = false;
  fits[3].mu_n = 1e9;  // would widen the interval if it were used
  const BootstrapReport r = SummariseBootstrap(kTruth, fits, ok, 0.1, 1e-3, o);
  EXPECT_EQ(r.replicates, 18);
  EXPECT_EQ(r.failed, 2);
  EXPECT_TRUE(r.K_mu.determined);
}

TEST(Bootstrap, OptionsAreValidated) {
  BootstrapOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.replicates = 18;  // their range holds a new refit 17 times in 19
  EXPECT_FALSE(o.Validate().ok());
  EXPECT_NE(o.Validate().ToString().find("at least 19"), std::string::npos) << o.Validate().ToString();
  o.replicates = 19;
  EXPECT_TRUE(o.Validate().ok());
  o.level = 0.8;
  o.replicates = 9;
  EXPECT_TRUE(o.Validate().ok());
  o.level = 0.9;
  o.replicates = 0;
  EXPECT_TRUE(o.Validate().ok());
  o.level = 1.0;
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace wormdrag
