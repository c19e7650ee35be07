// Decide on hand-made scores: each rule of the verdict and of "how far", and the
// explanation each rejection gives.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "core/common/json.h"
#include "core/common/stats.h"
#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using namespace test;

TEST(Decide, ShrinkIntervalRejectsAGainFromOneBlock) {
  DiagnoseOptions o;
  // 30 % better overall, all of it in one block: clears the bar, not the interval.
  Diagnosis one = Scores({10, 10, 10, 10, 10, 10, 10, -14});
  o.require_shrink_interval = false;
  Decide(o, &one);
  EXPECT_EQ(one.verdict, "lag");
  o.require_shrink_interval = true;
  Decide(o, &one);
  EXPECT_LE(one.effects[0].shrink_lo, 0);  // resamples without that block gain nothing
  EXPECT_NE(one.verdict, "lag");
  // The same gain spread over every block is significant either way.
  Diagnosis all = Scores({7, 7, 7, 7, 7, 7, 7, 7});
  Decide(o, &all);
  EXPECT_GT(all.effects[0].shrink_lo, 0.25);
  EXPECT_EQ(all.verdict, "lag");
}

// gap_offset is named only where the residual's jump at the dropped frames leaves, on
// the fitted a's side, the prediction interval of what the noise-only replicates' base
// fits show (DiagnoseOptions::require_gap_signature).
TEST(Decide, GapOffsetNeedsItsMarkInTheResidual) {
  // Replicates whose marks stay small: z −0.6 … 0.9, an interval of about −2.4 … 2.5.
  const std::vector<double> quiet = {0.3, -0.6, 0.9, -0.4};
  auto scored = [](double excess, double se, const std::vector<double>& null_z) {
    Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});
    d.effects[0].name = "gap_offset";
    d.effects[0].param_names = {"a"};
    d.effects[0].params = {0.3};
    NullFloor(&d, 0.1);  // a gap beyond noise, so that a rejected effect leaves it unexplained
    d.gap_signature.gaps = d.gap_signature.windows = 40;
    d.gap_signature.excess = excess;
    d.gap_signature.se = se;
    d.null_gap_z = null_z;
    return d;
  };
  DiagnoseOptions o;
  Diagnosis marked = scored(0.3, 0.02, quiet);
  Decide(o, &marked);
  EXPECT_EQ(marked.verdict, "gap_offset");
  const std::vector<double> negated = {-0.3, 0.6, -0.9, 0.4};
  EXPECT_NEAR(marked.gap_signature_hi, PredictionBound(quiet, 0.025), 1e-12);
  EXPECT_NEAR(marked.gap_signature_lo, -PredictionBound(negated, 0.025), 1e-12);
  EXPECT_LT(marked.gap_signature_hi, 3);
  // z = 4 is a mark beside quiet replicates, and none beside replicates that reach
  // z 2–3 from noise alone: then the gain comes from the path's progress as a whole.
  Diagnosis modest = scored(0.06, 0.015, quiet);
  Decide(o, &modest);
  EXPECT_EQ(modest.verdict, "gap_offset");
  Diagnosis unmarked = scored(0.06, 0.015, {2.5, 3.1, 1.9, 2.8});
  Decide(o, &unmarked);
  EXPECT_GT(unmarked.gap_signature_hi, 4);
  EXPECT_EQ(unmarked.verdict, "unexplained");
  EXPECT_NE(unmarked.explanation.find("does not jump where frames are missing"), std::string::npos)
      << unmarked.explanation;
  Diagnosis opposite = scored(-0.3, 0.02, quiet);  // a mark, but of the other sign than the fit's a
  Decide(o, &opposite);
  EXPECT_NE(opposite.verdict, "gap_offset");
  o.require_gap_signature = false;
  Decide(o, &unmarked);
  EXPECT_EQ(unmarked.verdict, "gap_offset");
  // Not measured on the data (too few runs of missing frames or windows elsewhere), or on
  // fewer than two replicates: not held to it.
  Diagnosis unknown = scored(0, 0, quiet);
  Decide(DiagnoseOptions{}, &unknown);
  EXPECT_EQ(unknown.verdict, "gap_offset");
  // A mark far out on the other side than the fitted a names nothing either.
  Diagnosis negative = scored(-0.3, 0.02, {2.5, 3.1, 1.9, 2.8});
  Decide(DiagnoseOptions{}, &negative);
  EXPECT_NE(negative.verdict, "gap_offset");
  Diagnosis no_null = scored(0.06, 0.015, {2.5});
  Decide(DiagnoseOptions{}, &no_null);
  EXPECT_EQ(no_null.verdict, "gap_offset");
}

// Held-out blocks restart on the measured pose, which hides a misfit that accumulates
// along the path: a base fit whose full path lies above the 97.5 % prediction bound of
// the noise-only refits' is never `none`, and the explanation says where the gap is.
TEST(Decide, AFullPathBeyondTheNoiseIsNeverNone) {
  auto scored = [](double path_mse) {
    Diagnosis d = Scores({10, 10, 10, 10, 10, 10, 10, 10});  // no effect gains anything
    d.path_mse = path_mse;
    d.null_path_mses = {0.18, 0.2, 0.22};  // the bound: 0.33 (log scale, Student t with 2 df, 2.5 %)
    d.null_path_mse = 0.2;
    d.null_path_sd = 0.02;
    d.where = {{"whole path", "mm", {{"all points (RMS)", std::sqrt(path_mse), 0.45, 0.49}}}};
    return d;
  };
  DiagnoseOptions o;
  Diagnosis within = scored(0.25);  // 1.25 × the refits': the held-out blocks decide
  Decide(o, &within);
  EXPECT_FALSE(within.gap_beyond_noise);
  EXPECT_FALSE(within.path_beyond_noise);
  EXPECT_EQ(within.verdict, "none");
  EXPECT_NE(within.explanation.find("nor its full path"), std::string::npos) << within.explanation;
  EXPECT_NE(within.explanation.find("97.5 % prediction bound"), std::string::npos) << within.explanation;
  EXPECT_NE(within.explanation.find("marks them but makes no gap"), std::string::npos) << within.explanation;
  Diagnosis beyond = scored(0.34);  // just above the bound
  Decide(o, &beyond);
  EXPECT_TRUE(beyond.path_beyond_noise);
  o.false_alarm_rate = 0.01;  // a stricter test: the bound rises to 0.63
  Decide(o, &beyond);
  EXPECT_FALSE(beyond.path_beyond_noise);
  o.false_alarm_rate = 0.05;
  Diagnosis drifting = scored(20.0);  // 100 ×, the held-out blocks as before
  Decide(o, &drifting);
  EXPECT_FALSE(drifting.gap_beyond_noise);
  EXPECT_TRUE(drifting.path_beyond_noise);
  EXPECT_EQ(drifting.verdict, "unexplained");
  EXPECT_NE(drifting.explanation.find("full path drifts beyond tracking noise"), std::string::npos)
      << drifting.explanation;
  // Five times the refits' mean, but the refits themselves spread over a factor 6: no gap.
  Diagnosis erratic = scored(1.5);
  erratic.null_path_mses = {0.1, 0.2, 0.6};
  Decide(o, &erratic);
  EXPECT_FALSE(erratic.path_beyond_noise);
  EXPECT_EQ(erratic.verdict, "none");
  // Without noise-only replicates there is no full-path floor, and no test.
  Diagnosis unscored = scored(20.0);
  unscored.null_path_mses.clear();
  unscored.null_path_mse = unscored.null_path_sd = 0;
  Decide(o, &unscored);
  EXPECT_EQ(unscored.verdict, "none");
  o.false_alarm_rate = 0;
  EXPECT_FALSE(o.Validate().ok());
  o.false_alarm_rate = 1;
  EXPECT_FALSE(o.Validate().ok());
}

// The gap is the union of the held-out test and the full-path test. On data drawn as the
// replicates are (both scores log-normal and independent), it opens at the false-alarm
// rate, 1 − 0.975² ≈ 0.049; at 5 % each the union would open at 0.0975.
TEST(Decide, TheTwoGapTestsTogetherKeepTheFalseAlarmRate) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> cv_log(std::log(1e-4), 0.3), path_log(std::log(4e-4), 0.5);
  DiagnoseOptions o;
  int opened = 0;
  const int trials = 4000;
  for (int k = 0; k < trials; ++k) {
    Diagnosis d = Scores({10, 10, 10, 10, 10, 10, 10, 10});
    d.effects.clear();  // the gap tests alone
    d.null_base_cv_mses.clear();
    d.null_path_mses.clear();
    for (int r = 0; r < 5; ++r) {
      d.null_base_cv_mses.push_back(std::exp(cv_log(rng)));
      d.null_path_mses.push_back(std::exp(path_log(rng)));
    }
    d.null_path_mse = Summarize(d.null_path_mses).mean;
    d.base_cv.cv_mse = std::exp(cv_log(rng));
    d.path_mse = std::exp(path_log(rng));
    Decide(o, &d);
    opened += d.verdict != "none";
    EXPECT_EQ(d.verdict != "none", d.gap_beyond_noise || d.path_beyond_noise);
  }
  EXPECT_NEAR(opened / static_cast<double>(trials), 1 - 0.975 * 0.975, 0.012);
}

// A named effect is clear when its gain is at least clear_margin (2) times its bar, else
// tentative; the grade changes no verdict, and none/unexplained get none.
TEST(Decide, ANamedEffectIsClearOrTentative) {
  DiagnoseOptions o;
  Diagnosis strong = Scores({7, 7, 7, 7, 7, 7, 7, 7});  // gain 1 - 0.707 against the bar 0.12
  Decide(o, &strong);
  EXPECT_EQ(strong.verdict, "lag");
  EXPECT_EQ(strong.confidence, "clear");
  EXPECT_NEAR(strong.margin, (1 - 0.7 * 1.01) / 0.12, 1e-9);
  EXPECT_EQ(strong.explanation.find("Tentative"), std::string::npos) << strong.explanation;
  Diagnosis weak = Scores({8.5, 8.5, 8.5, 8.5, 8.5, 8.5, 8.5, 8.5});  // gain 0.14: 1.18 times the bar
  Decide(o, &weak);
  EXPECT_EQ(weak.verdict, "lag");
  EXPECT_EQ(weak.confidence, "tentative");
  EXPECT_NEAR(weak.margin, (1 - 0.85 * 1.01) / 0.12, 1e-9);
  EXPECT_NE(weak.explanation.find("Tentative: its gain is only 1.18 times"), std::string::npos) << weak.explanation;
  EXPECT_NE(weak.ToJson().find("\"confidence\":\"tentative\""), std::string::npos);
  EXPECT_EQ(weak.ToText().rfind("verdict: lag (tentative)\n", 0), 0u) << weak.ToText().substr(0, 80);
  o.clear_margin = 1.1;
  Decide(o, &weak);
  EXPECT_EQ(weak.confidence, "clear");
  EXPECT_EQ(weak.verdict, "lag");
  // The SIMEX-corrected gain counts when it is the smaller: 0.35 on a noisier copy
  // leaves 0.293 - (0.35 - 0.293) = 0.236, 1.97 times the bar.
  o.clear_margin = 2;
  strong.simex_base_mse = {1.0};
  strong.effects[0].simex_mse = {0.65 / 1.01};
  Decide(o, &strong);
  EXPECT_EQ(strong.verdict, "lag");
  EXPECT_NEAR(strong.margin, (2 * (1 - 0.7 * 1.01) - 0.35) / 0.12, 1e-9);
  EXPECT_EQ(strong.confidence, "tentative");
  Diagnosis nothing = Scores({10, 10, 10, 10, 10, 10, 10, 10});
  Decide(o, &nothing);
  EXPECT_EQ(nothing.verdict, "none");
  EXPECT_TRUE(nothing.confidence.empty());
  o.clear_margin = 0.9;
  EXPECT_FALSE(o.Validate().ok());
}

// The verdict gives the effect's parameter with an interval, so an effect whose fits never
// moved its parameter from a start is not named, however much it gains
// (DiagnoseOptions::require_estimated_params).
TEST(Decide, AnUnestimatedParameterIsNeverTheVerdict) {
  DiagnoseOptions o;
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});
  NullFloor(&d, 0.1);  // a gap beyond noise
  d.effects[0].estimated = false;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "unexplained");
  EXPECT_FALSE(d.effects[0].significant);
  EXPECT_NE(d.explanation.find("did not estimate it"), std::string::npos) << d.explanation;
  o.require_estimated_params = false;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  d.effects[0].estimated = true;
  Decide(DiagnoseOptions{}, &d);
  EXPECT_EQ(d.verdict, "lag");
}

// How far comes from the effect's own refit when there is one; whether the effect is
// significant still comes from the base-centred scores the null calibrates.
TEST(Decide, HowFarFromTheEffectsOwnFit) {
  DiagnoseOptions o;
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  EXPECT_NEAR(d.e_after, 0.7, 1e-12);
  d.effects[0].refined = true;
  d.effects[0].own_block_sum.assign(8, 5.0);
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  EXPECT_NEAR(d.e_after, 0.5, 1e-12);
  EXPECT_NEAR(d.shrink_mm, 0.5, 1e-12);
  EXPECT_NEAR(d.effects[0].improvement, 1 - 0.7 * 1.01, 1e-12);  // base-centred
  EXPECT_LE(d.e_after_lo, 0.5);
  EXPECT_GE(d.e_after_hi, 0.5);
  // An own refit that helps less than the base-centred fits is reported as it is.
  d.effects[0].own_block_sum.assign(8, 9.0);
  Decide(o, &d);
  EXPECT_NEAR(d.e_after, 0.9, 1e-12);
  // Refits switched off (refine_top 0) or too few own block sums (a saved state from
  // before the refits): the base-centred ones.
  o.refine_top = 0;
  Decide(o, &d);
  EXPECT_NEAR(d.e_after, 0.7, 1e-12);
  o.refine_top = 1;
  d.effects[0].own_block_sum.assign(3, 1.0);
  Decide(o, &d);
  EXPECT_NEAR(d.e_after, 0.7, 1e-12);
}

// An effect's bar is the 95 % prediction bound of the held-out reduction it reaches on
// the noise-only replicates, over the data's base score: the same noise artefact is a
// smaller share of a base far above the noise.
TEST(Decide, BarIsThePredictionBoundOfTheNullsReductions) {
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});  // gain 1 − 0.7 × 1.01 = 0.293
  // Noise-only gains of 0.2, 0.25 and 0.15 on replicate base scores of 0.9, 1.0 and 1.1.
  d.effects[0].null_improvements = {0.8 / 1.01, 0.75 / 1.01, 0.85 / 1.01};
  const double bound = PredictionBound({0.9 * 0.2, 0.25, 1.1 * 0.15}, 0.05);
  DiagnoseOptions o;
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].threshold, bound, 1e-9);
  EXPECT_GT(bound, 0.293);
  EXPECT_FALSE(d.effects[0].significant);
  EXPECT_EQ(d.verdict, "none");
  // The same replicates beside a base score four times as high, and the same relative
  // gain: the bar is a quarter, and the floor min_improvement holds.
  d.base_cv.cv_mse = 4;
  d.effects[0].cv_mse *= 4;
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].threshold, std::max(o.min_improvement, bound / 4), 1e-9);
  EXPECT_TRUE(d.effects[0].significant);
  // A laxer false-alarm rate lowers the bar on the first data.
  d.base_cv.cv_mse = 1;
  d.effects[0].cv_mse /= 4;
  o.false_alarm_rate = 0.3;
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].threshold, PredictionBound({0.9 * 0.2, 0.25, 1.1 * 0.15}, 0.3), 1e-9);
  EXPECT_LT(d.effects[0].threshold, 0.293);
  EXPECT_EQ(d.verdict, "lag");
}

TEST(Decide, UnreachableBarIsSaidSo) {
  // Noise-only refits that gain 0, 0.9 and 0 give a bar above 1: the effect could not
  // have been significant, and the explanation says so instead of "not significant".
  // The full path makes the gap.
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});
  d.effects[0].null_improvements = {1.0, 0.1 / 1.01, 1.0};
  d.path_mse = 20;
  d.null_path_mses = {0.18, 0.2, 0.22};
  d.null_path_mse = 0.2;
  DiagnoseOptions o;
  Decide(o, &d);
  EXPECT_GE(d.effects[0].threshold, 1.0);
  EXPECT_EQ(d.verdict, "unexplained");
  EXPECT_NE(d.explanation.find("above 1"), std::string::npos) << d.explanation;
  EXPECT_NE(d.ToText().find("not detectable on this pair"), std::string::npos);
}

// SIMEX check: a gain that grows when tracking noise is added to the data is a bias of
// the noisy drive; extrapolated back toward no noise it must still clear the bar.
TEST(Decide, GainThatGrowsWithAddedNoiseIsNotAnEffect) {
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});  // improvement 1 − 0.7 × 1.01 = 0.293; bar 0.12
  d.simex_base_mse = {1.5, 1.5, 1.5};
  // With noise added the effect gains 0.6 (of the data's base score 1) on every copy.
  d.effects[0].simex_mse.assign(3, 0.9 / 1.01);
  DiagnoseOptions o;
  o.simex_weight = 0;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");  // off: reported, not used
  EXPECT_NEAR(d.effects[0].simex_gain, 0.6, 1e-12);
  o.simex_weight = 1;
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].simex_corrected, 0.293 - (0.6 - 0.293), 1e-12);
  EXPECT_FALSE(d.effects[0].significant);
  EXPECT_EQ(d.verdict, "none");
  // A gain that stays put (one copy jumping to another minimum: the median ignores it).
  d.effects[0].simex_mse = {1.21 / 1.01, 1.22 / 1.01, 0.5 / 1.01};
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].simex_gain, 0.29, 1e-12);
  EXPECT_NEAR(d.effects[0].simex_corrected, 0.293, 1e-12);  // a falling gain is not rewarded
  EXPECT_EQ(d.verdict, "lag");
  // With a gap beyond noise the rejected effect leaves the gap unexplained, and says why.
  d.effects[0].simex_mse.assign(3, 0.9 / 1.01);
  NullFloor(&d, 0.1);
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "unexplained");
  EXPECT_NE(d.explanation.find("grows with the noise"), std::string::npos) << d.explanation;
  EXPECT_NE(d.ToText().find("with noise added: gain +0.600"), std::string::npos) << d.ToText();
  o.simex_weight = -1;
  EXPECT_FALSE(o.Validate().ok());
}

// The other side: a gain that all but vanishes on the noisy copies fits this
// recording's chance pattern, not the body.
TEST(Decide, GainThatVanishesWithAddedNoiseIsNotAnEffect) {
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});  // improvement 0.293
  d.simex_base_mse = {1.5, 1.5, 1.5};
  d.effects[0].simex_mse.assign(3, 1.45 / 1.01);  // gain 0.05 on every copy
  DiagnoseOptions o;
  o.simex_min_keep = 0;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  o.simex_min_keep = 0.3;
  Decide(o, &d);
  EXPECT_FALSE(d.effects[0].significant);
  EXPECT_EQ(d.verdict, "none");
  d.effects[0].simex_mse.assign(3, 1.3 / 1.01);  // gain 0.2: kept
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  d.effects[0].simex_mse.assign(3, 1.45 / 1.01);
  NullFloor(&d, 0.1);  // a gap beyond noise: unexplained, and why
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "unexplained");
  EXPECT_NE(d.explanation.find("only 0.05 when tracking noise is added"), std::string::npos) << d.explanation;
  o.simex_min_keep = 1.5;
  EXPECT_FALSE(o.Validate().ok());
}

// The noisy copies measure the model error an effect leaves (2 × MSE − MSE on the
// copies, over the base's): reported, and NaN where the base's error is all noise. It
// does not turn a share of the gap below explained_share into a verdict.
TEST(Decide, ModelErrorLeftIsReported) {
  Diagnosis d = Scores({5, 5, 5, 5, 5, 5, 5, 5});  // improvement 1 − 0.5 × 1.01 ≈ 0.5
  NullFloor(&d, 0.1);                              // a gap beyond noise
  d.null_base_cv_e = 0.2;                          // E 1 → 0.5 is 62 % of the gap above 0.2
  d.simex_base_mse = {1.2, 1.2, 1.2};              // the base's model error: 2 × 1 − 1.2 = 0.8
  d.effects[0].simex_mse.assign(3, 0.9);           // the effect's: 2 × 0.5 − 0.9 = 0.1
  DiagnoseOptions o;
  o.simex_weight = 0;
  o.simex_min_keep = 0;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "unexplained");
  EXPECT_NEAR(d.effects[0].simex_residual, 0.1 / 0.8, 1e-12);
  const Json reported = Json::parse(d.ToJson())["which"]["effects"][0]["simex"]["model_error_left"];
  ASSERT_TRUE(reported.is_number()) << d.ToJson();
  EXPECT_NEAR(reported.get<double>(), 0.125, 1e-12);
  // A base whose error is all noise gives no ratio.
  d.simex_base_mse.assign(3, 2.5);
  Decide(o, &d);
  EXPECT_TRUE(std::isnan(d.effects[0].simex_residual));
  EXPECT_EQ(d.verdict, "unexplained");
}

// A refined effect is scored by its own fit's fold fits when they do better than the
// base-centred ones, and its shrink interval comes from the same fits.
TEST(Decide, RefinedEffectIsScoredByItsOwnFit) {
  Diagnosis d = Scores({9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5});  // improvement 0.04: below the bar
  d.effects[0].refined = true;
  d.effects[0].own_block_sum.assign(8, 6.0);
  d.effects[0].own_cv_mse = 0.6;
  DiagnoseOptions o;
  o.score_refined_fit = false;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "none");
  EXPECT_FALSE(d.effects[0].scored_own);
  o.score_refined_fit = true;
  Decide(o, &d);
  EXPECT_TRUE(d.effects[0].scored_own);
  EXPECT_NEAR(d.effects[0].improvement, 1 - 0.6 * 1.01, 1e-12);
  EXPECT_NEAR(d.effects[0].shrink_lo, 0.4, 1e-12);  // every block 0.4 better
  EXPECT_EQ(d.verdict, "lag");
  // An own fit that does worse is not used.
  d.effects[0].own_cv_mse = 1.2;
  Decide(o, &d);
  EXPECT_FALSE(d.effects[0].scored_own);
  EXPECT_EQ(d.verdict, "none");
}

// The noisy copies score a refined effect as the data do: when its own fit scores it on
// the data, the better of its base-centred and own-centred fits scores it on each copy.
// Base-centred fits alone cannot undo the base's compensation there either, and the
// gain would seem to vanish with the noise (a benchmark time_drift 0.8: 0.95 on the data
// from its own fit, 0.04 on the copies from the base-centred fits).
TEST(Decide, CopiesScoreARefinedEffectByItsOwnFitAsTheDataDo) {
  Diagnosis d = Scores({9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5});
  d.effects[0].refined = true;
  d.effects[0].own_block_sum.assign(8, 6.0);
  d.effects[0].own_cv_mse = 0.6;  // improvement 1 − 0.606 = 0.394 from its own fit
  d.simex_base_mse = {1.5, 1.5, 1.5};
  d.effects[0].simex_mse.assign(3, 1.48 / 1.01);  // base-centred on the copies: gain 0.02
  DiagnoseOptions o;
  Decide(o, &d);
  EXPECT_TRUE(d.effects[0].scored_own);
  EXPECT_NEAR(d.effects[0].simex_gain, 0.02, 1e-12);
  EXPECT_EQ(d.verdict, "none");                                       // the gain vanished: 0.02 < 0.3 × 0.394
  d.effects[0].simex_own_mse = {1.1 / 1.01, 1.0 / 1.01, 1.6 / 1.01};  // own-centred: 0.4, 0.5, worse
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].simex_gain, 0.4, 1e-12);  // median of 0.4, 0.5, 0.02
  EXPECT_EQ(d.verdict, "lag");
  // Not scored by its own fit on the data: not on the copies either.
  o.score_refined_fit = false;
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].simex_gain, 0.02, 1e-12);
  // Own-centred scores missing for a copy (the check fell back to the base-centred fits):
  // base-centred only.
  o.score_refined_fit = true;
  d.effects[0].simex_own_mse.pop_back();
  Decide(o, &d);
  EXPECT_NEAR(d.effects[0].simex_gain, 0.02, 1e-12);
}

// With the check on, an effect it did not examine cannot win once the examined ones are
// rejected (docs/decisions/0021-simex-check.md: else a rejected power_law pair goes to
// an unchecked lateral_asymmetry).
TEST(Decide, EffectTheCheckDidNotExamineIsNotNamed) {
  Diagnosis d = Scores({7, 7, 7, 7, 7, 7, 7, 7});
  d.simex_base_mse = {1.5, 1.5, 1.5};
  d.effects[0].simex_mse.assign(3, 0.9 / 1.01);  // lag: its gain grows with the noise
  EffectFit unchecked = d.effects[0];
  unchecked.name = "time_drift";
  unchecked.simex_mse.clear();
  unchecked.block_sum = {8, 8, 8, 8, 8, 8, 8, 8};
  unchecked.cv_mse = 64 / 80.0;  // gain 0.19: clears the bar
  d.effects.push_back(unchecked);
  DiagnoseOptions o;
  o.simex_weight = 0;
  o.simex_min_keep = 0;
  Decide(o, &d);
  EXPECT_EQ(d.verdict, "lag");
  o.simex_weight = 4;
  Decide(o, &d);
  EXPECT_FALSE(d.effects[1].significant);
  EXPECT_EQ(d.verdict, "none");
}

}  // namespace
}  // namespace wormdrag::diagnose
