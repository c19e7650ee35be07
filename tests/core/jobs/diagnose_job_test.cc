// The wire form of a diagnosis's pieces: options and fit tasks survive JSON exactly,
// and a malformed task is refused with a message, never run.
#include <gtest/gtest.h>

#include "core/diagnose/diagnosis.h"
#include "core/jobs/diagnose_job.h"

namespace wormdrag {
namespace {

TEST(DiagnoseJobJson, FitTaskRoundTripsStartsAndRidge) {
  diagnose::FitTask t;
  t.replicate = 3;
  t.null_base = {0.4, 0.1, 0.004, 0.001};
  t.null_sigma = 0.002;
  t.spec.has_effect = true;
  t.spec.effect = diagnose::Effect::kLag;
  t.spec.effect_starts = {{0.0}, {0.08}};
  t.spec.start = {0.5, 0.2, 0.005, 0.002};
  t.spec.extra_starts = diagnose::BaseStarts(t.spec.start);
  t.spec.prior = {0.45, 0.15, 0.0045, 0.0015};
  t.spec.prior_weight = 0.0014;
  t.spec.train_parity = 1;
  auto back = FitTaskFromJson(FitTaskToJson(t));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->replicate, 3);
  EXPECT_EQ(back->spec.effect, diagnose::Effect::kLag);
  EXPECT_EQ(back->spec.effect_starts, t.spec.effect_starts);
  ASSERT_EQ(back->spec.extra_starts.size(), t.spec.extra_starts.size());
  for (size_t i = 0; i < t.spec.extra_starts.size(); ++i) {
    EXPECT_DOUBLE_EQ(back->spec.extra_starts[i].mu_n, t.spec.extra_starts[i].mu_n);
    EXPECT_DOUBLE_EQ(back->spec.extra_starts[i].eta_t, t.spec.extra_starts[i].eta_t);
  }
  EXPECT_DOUBLE_EQ(back->spec.prior.mu_t, 0.15);
  EXPECT_DOUBLE_EQ(back->spec.prior_weight, 0.0014);
  EXPECT_EQ(FitTaskToJson(*back), FitTaskToJson(t));
}

TEST(DiagnoseJobJson, NegativeRidgeIsRefused) {
  diagnose::FitTask t;
  t.spec.start = {0.5, 0.2, 0.005, 0.002};
  t.spec.prior_weight = -1;
  auto back = FitTaskFromJson(FitTaskToJson(t));
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.status().ToString().find("prior_weight"), std::string::npos) << back.status().ToString();
}

// A per-worm fit (each worm its own effect parameters) keeps that on the wire, and its
// result carries both worms' values: the worker's 6 + 2·n values split back per worm.
TEST(DiagnoseJobJson, PerWormFitTaskAndResultRoundTrip) {
  diagnose::FitTask t;
  t.spec.has_effect = true;
  t.spec.effect = diagnose::Effect::kTimeDrift;
  t.spec.per_worm = true;
  t.spec.effect_starts = {{0.2}, {0.1, -0.3}};
  t.spec.start = {0.5, 0.2, 0.005, 0.002};
  auto back = FitTaskFromJson(FitTaskToJson(t));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_TRUE(back->spec.per_worm);
  EXPECT_EQ(back->spec.effect_starts, t.spec.effect_starts);

  auto f = FitOutcomeFromValues({0.5, 0.2, 0.005, 0.002, 1e-6, 40, 0.7, -0.4}, *back);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_DOUBLE_EQ(f->effects.time_drift, 0.7);
  EXPECT_DOUBLE_EQ(f->second_worm_effects.time_drift, -0.4);
  EXPECT_FALSE(FitOutcomeFromValues({0.5, 0.2, 0.005, 0.002, 1e-6, 40, 0.7}, *back).ok());

  // A shared fit refuses both worms' starts, and a task without the field is shared.
  t.spec.per_worm = false;
  EXPECT_FALSE(FitTaskFromJson(FitTaskToJson(t)).ok());
  t.spec.effect_starts = {{0.2}};
  std::string old = FitTaskToJson(t);
  old.erase(old.find(",\"per_worm\":false"), std::string(",\"per_worm\":false").size());
  auto shared = FitTaskFromJson(old);
  ASSERT_TRUE(shared.ok()) << shared.status().ToString() << " in " << old;
  EXPECT_FALSE(shared->spec.per_worm);
}

TEST(DiagnoseJobJson, OptionsKeepTheSmoothing) {
  diagnose::DiagnoseOptions o;
  o.smoothing = SmoothingMethod::kAuto;
  o.spline.order = 2;
  auto back = DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->smoothing, SmoothingMethod::kAuto);
  EXPECT_EQ(back->spline.order, 2);
  // The default smooths as the estimate does (decision 0040) ...
  EXPECT_EQ(diagnose::DiagnoseOptions{}.smoothing, SmoothingMethod::kAuto);
  // ... but options stored before smoothing was a choice read as the low-pass they ran with.
  auto old = DiagnoseOptionsFromJson(R"({"lowpass_hz": 5})");
  ASSERT_TRUE(old.ok()) << old.status().ToString();
  EXPECT_EQ(old->smoothing, SmoothingMethod::kLowpass);
  auto bad = DiagnoseOptionsFromJson(R"({"smoothing": "butterworth"})");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("butterworth"), std::string::npos) << bad.status().message();
}

TEST(DiagnoseJobJson, OptionsKeepTheCvSettings) {
  diagnose::DiagnoseOptions o;
  o.cv_ridge = 1.25;
  o.base_multistart = false;
  o.refine_top = 3;
  o.false_alarm_rate = 0.1;
  o.simex_draws = 5;
  o.simex_top = 1;
  o.simex_weight = 0.75;
  o.simex_min_keep = 0.25;
  o.score_refined_fit = !o.score_refined_fit;
  auto back = DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_DOUBLE_EQ(back->cv_ridge, 1.25);
  EXPECT_FALSE(back->base_multistart);
  EXPECT_EQ(back->refine_top, 3);
  EXPECT_DOUBLE_EQ(back->false_alarm_rate, 0.1);
  EXPECT_EQ(back->simex_draws, 5);
  EXPECT_EQ(back->simex_top, 1);
  EXPECT_DOUBLE_EQ(back->simex_weight, 0.75);
  EXPECT_DOUBLE_EQ(back->simex_min_keep, 0.25);
  EXPECT_EQ(back->score_refined_fit, o.score_refined_fit);
  o.refine_top = -1;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
  o.refine_top = 1;
  o.false_alarm_rate = 0;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
  o.false_alarm_rate = 0.05;
  o.simex_weight = -1;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
  o.simex_weight = 0;
  o.simex_min_keep = 1.5;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
  o.simex_min_keep = 0;
  o.simex_draws = 51;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
  o.simex_draws = 3;
  o.cv_ridge = -0.5;
  EXPECT_FALSE(DiagnoseOptionsFromJson(DiagnoseOptionsToJson(o)).ok());
}

}  // namespace
}  // namespace wormdrag
