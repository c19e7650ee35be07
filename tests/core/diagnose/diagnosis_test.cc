// Whole diagnoses of short synthetic pairs with an in-process fit runner: the nested
// fallback, the own refit, the SIMEX copies, unestimated parameters, cautions.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <gtest/gtest.h>

#include "core/common/stats.h"
#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using namespace test;

// A fold fit of an effect model that ends above the base model's training error (a lost
// optimiser) is replaced by the base's fold fit with the effect neutral.
TEST(Diagnose, LostEffectFitFallsBackToTheNestedBase) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  // Every effect fit is "lost": far from the data, with a training error above any base fit.
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag"}, [](const FitTask& t, FitOutcome* f) {
    if (!t.spec.has_effect) return;
    f->coef = {1e-3, 1.0, 1e-5, 1e-5};
    f->train_mse = 1e9;
  });
  o.refine_top = 0;  // the effect's own refit would replace the estimate checked below
  for (bool fallback : {true, false}) {
    o.nested_fallback = fallback;
    auto d = RunDiagnosis(pair, {"a", "b"}, o);
    ASSERT_TRUE(d.ok()) << d.status().ToString();
    ASSERT_EQ(d->effects.size(), 1u);
    if (fallback) {
      EXPECT_DOUBLE_EQ(d->effects[0].cv_mse, d->base_cv.cv_mse);
      EXPECT_DOUBLE_EQ(d->effects[0].params[0], 0.0);  // lag at its neutral value
    } else {
      EXPECT_GT(d->effects[0].cv_mse, 2 * d->base_cv.cv_mse);
    }
  }
}

// Fits that end where they started leave the parameter unestimated: its interval is the
// admissible range and the text says so. Here every lag fit (the folds from the starts 0
// and 0.08, the own refit from their mean, its folds) is put back at its start, as
// stiction's fits end on the benchmark; time_drift's fits, on a pair that has it, are left
// as they are.
TEST(Diagnose, FitsThatNeverLeaveTheirStartLeaveTheParameterUnestimated) {
  EffectParams drifting;
  drifting.time_drift = 0.8;
  const auto pair = Pair(drifting, 0.002, 31, 40, 1.6);
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag", "time_drift"}, [](const FitTask& t, FitOutcome* f) {
    if (!t.spec.has_effect || t.spec.effect != Effect::kLag) return;
    const auto& starts = t.spec.effect_starts;
    f->params = t.spec.train_parity == 1 ? starts.back() : starts.front();
    SetParams(&f->effects, Effect::kLag, f->params);
  });
  // The hook moves the estimates but leaves each fit's training error, so the nested
  // fallback would compare errors of parameters the fits no longer hold: whether a lag
  // fold ends a hair above the base's then depends on the last bits of the optimiser's
  // path, which differ between CPUs. The fallback has its own test above.
  o.nested_fallback = false;
  for (int refine : {0, 1}) {
    o.refine_top = refine;
    auto d = RunDiagnosis(pair, {"a", "b"}, o);
    ASSERT_TRUE(d.ok()) << d.status().ToString();
    ASSERT_EQ(d->effects.size(), 2u);
    const EffectFit& lag = d->effects[0];
    const EffectFit& drift = d->effects[1];
    ASSERT_EQ(lag.name, "lag");
    EXPECT_FALSE(lag.estimated) << "refine_top " << refine;
    EXPECT_NEAR(lag.params[0], 0.04, 1e-12);  // the folds' mean of 0 and 0.08
    EXPECT_EQ(lag.param_lo[0], InfoOf(Effect::kLag).lower[0]);
    EXPECT_EQ(lag.param_hi[0], InfoOf(Effect::kLag).upper[0]);
    EXPECT_FALSE(lag.significant);
    EXPECT_NE(d->ToText().find("delta = 0.04 (not estimated"), std::string::npos) << d->ToText();
    EXPECT_NE(d->ToJson().find("\"estimated\":false"), std::string::npos);
    EXPECT_TRUE(drift.estimated) << "refine_top " << refine << ": a = " << drift.params[0];
    EXPECT_GT(drift.param_lo[0], InfoOf(Effect::kTimeDrift).lower[0]);  // an interval, not the admissible range
  }
}

// How far: the closest effect is refitted with all blocks and free coefficients (no
// ridge, started from the base-centred estimate), then its two fold fits start from and
// are held near that refit; its estimate and "how far" come from them.
TEST(Diagnose, ClosestEffectIsRefittedOnItsOwn) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  std::vector<std::pair<FitTask, FitOutcome>> runs;
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag", "time_drift"},
                                     [&](const FitTask& t, FitOutcome* f) { runs.emplace_back(t, *f); });
  o.refine_top = 1;
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  // The refit: the only all-block effect fit, on the data, without a ridge.
  std::vector<size_t> own;
  for (size_t k = 0; k < runs.size(); ++k)
    if (runs[k].first.spec.has_effect && runs[k].first.spec.train_parity < 0) own.push_back(k);
  ASSERT_EQ(own.size(), 1u);
  const auto& [refit_task, refit] = runs[own[0]];
  EXPECT_EQ(refit_task.replicate, 0);
  EXPECT_EQ(refit_task.spec.prior_weight, 0);
  EXPECT_EQ(refit_task.spec.extra_starts.size(), BaseStarts(d->cv_base).size() + 1);  // corners + the start
  // Its two fold fits come right after it, centred on it (then the SIMEX check's fits).
  ASSERT_GE(runs.size(), own[0] + 3);
  for (int parity = 0; parity < 2; ++parity) {
    const FitSpec& fs = runs[own[0] + 1 + parity].first.spec;
    EXPECT_EQ(fs.train_parity, parity);
    EXPECT_EQ(fs.effect, refit_task.spec.effect);
    EXPECT_EQ(fs.start.ToString(), refit.coef.ToString());
    EXPECT_EQ(fs.prior.ToString(), refit.coef.ToString());
    EXPECT_NEAR(fs.prior_weight, o.cv_ridge * std::sqrt(2.0) * d->noise_sigma, 1e-15);
    EXPECT_EQ(fs.effect_starts, std::vector<std::vector<double>>{refit.params});
  }
  int refined = 0;
  for (const auto& f : d->effects) {
    if (!f.refined) continue;
    ++refined;
    EXPECT_EQ(f.name, InfoOf(refit_task.spec.effect).name);
    EXPECT_EQ(f.coef.ToString(), refit.coef.ToString());
    EXPECT_EQ(f.params, refit.params);
    EXPECT_EQ(f.own_block_sum.size(), f.block_count.size());
    EXPECT_DOUBLE_EQ(d->e_after, f.own_cv_e_mm);  // the closest effect is the one shown
  }
  EXPECT_EQ(refined, 1);
}

// A free refit can end where nothing simulates; the diagnosis then stands on the
// base-centred fits and says so, rather than failing.
TEST(Diagnose, FailedRefitLeavesTheBaseCentredFits) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag"}, [](const FitTask&, FitOutcome*) {});
  o.simex_draws = 0;
  const FitRunner fits = o.run_fits;
  o.run_fits = [fits](const std::vector<FitTask>& tasks) -> Result<std::vector<FitOutcome>> {
    for (const auto& t : tasks)
      if (t.replicate == 0 && t.spec.has_effect && t.spec.train_parity < 0)
        return Status::FailedPrecondition("the fit found no set that could be simulated");
    return fits(tasks);
  };
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  ASSERT_EQ(d->effects.size(), 1u);
  const EffectFit& f = d->effects[0];
  EXPECT_TRUE(f.testable);
  EXPECT_FALSE(f.refined);
  EXPECT_NE(f.note.find("its own refit failed"), std::string::npos) << f.note;
  EXPECT_NE(d->ToText().find("its own refit failed"), std::string::npos);
  // A cancellation during the refits still cancels.
  o.run_fits = [fits](const std::vector<FitTask>& tasks) -> Result<std::vector<FitOutcome>> {
    for (const auto& t : tasks)
      if (t.replicate == 0 && t.spec.has_effect && t.spec.train_parity < 0) return Status::Cancelled("stop");
    return fits(tasks);
  };
  EXPECT_EQ(RunDiagnosis(pair, {"a", "b"}, o).status().code(), Status::Code::kCancelled);
}

// Recordings shorter than kReliableSpanSeconds per worm are diagnosed with a caution
// (in the text, JSON and HTML); 5 s per worm carries none.
TEST(Diagnose, ShortRecordingsCarryACaution) {
  for (double dur : {1.6, 5.0}) {
    const double fps = 20;
    const auto pair = Pair(EffectParams{}, 0.002, 31, fps, dur);
    DiagnoseOptions o = QuickDiagnosis(pair, {"lag"}, [](const FitTask&, FitOutcome*) {});
    o.simex_draws = 0;
    o.refine_top = 0;
    auto d = RunDiagnosis(pair, {"a", "b"}, o);
    ASSERT_TRUE(d.ok()) << d.status().ToString();
    EXPECT_NEAR(d->span_s, dur, 1.01 / fps) << dur;
    if (dur < kReliableSpanSeconds) {
      ASSERT_EQ(d->cautions.size(), 1u) << dur;
      EXPECT_NE(d->cautions[0].find("1.6 s per worm"), std::string::npos) << d->cautions[0];
      EXPECT_NE(d->ToText().find("caution: The recordings give 1.6 s per worm"), std::string::npos);
      EXPECT_NE(d->ToJson().find("\"cautions\":[\"The recordings give 1.6 s"), std::string::npos);
      EXPECT_NE(d->ToHtml().find("Caution:"), std::string::npos);
    } else {
      // The HTML draws the residual over time, one bar chart per "where" breakdown and
      // the effects' chart, all through the one SVG module.
      const std::string html = d->ToHtml();
      size_t figures = 0;
      for (size_t pos = 0; (pos = html.find("<svg", pos)) != std::string::npos; ++pos) ++figures;
      EXPECT_EQ(figures, 2 + d->where.size());
      EXPECT_NE(html.find("mean distance (mm)"), std::string::npos);
      EXPECT_NE(html.find("noise bound"), std::string::npos);
      // Each cell is marked against the replicates' prediction bound: finite, above their mean.
      for (const auto& w : d->where)
        for (const auto& c : w.cells) {
          EXPECT_TRUE(std::isfinite(c.null_hi)) << w.name << " " << c.label;
          EXPECT_GE(c.null_hi, c.null_mean) << w.name << " " << c.label;
        }
      EXPECT_TRUE(d->cautions.empty()) << d->cautions[0];
      EXPECT_NE(d->ToJson().find("\"cautions\":[]"), std::string::npos);
      EXPECT_EQ(d->ToText().find("caution:"), std::string::npos);
      // The full path is measured on the data and on every noise-only replicate, and
      // heads the "where" table.
      EXPECT_GT(d->path_mse, 0);
      EXPECT_GT(d->null_path_mse, 0);
      ASSERT_FALSE(d->where.empty());
      EXPECT_EQ(d->where[0].name, "whole path");
      EXPECT_NEAR(d->where[0].cells[0].value, std::sqrt(d->path_mse), 1e-12);
      EXPECT_NE(d->ToJson().find("\"path_beyond_noise\""), std::string::npos);
    }
  }
}

// gap_offset's mark is measured on the data and on each noise-only replicate's own base
// fit (the replicates drop the data's frames), and the replicates' z set its interval.
TEST(Diagnose, GapOffsetsMarkIsMeasuredOnTheReplicatesToo) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 20, 3.0, GapPattern{8, 2, 4});
  DiagnoseOptions o = QuickDiagnosis(pair, {"gap_offset"}, [](const FitTask&, FitOutcome*) {});
  o.null_replicates = 3;
  o.simex_draws = 0;
  o.refine_top = 0;
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  ASSERT_TRUE(d->gap_signature.Measured());
  ASSERT_EQ(d->null_gap_z.size(), 3u);
  EXPECT_NEAR(d->gap_signature_hi, PredictionBound(d->null_gap_z, o.false_alarm_rate / 2), 1e-12);
  for (double z : d->null_gap_z) {
    EXPECT_GT(d->gap_signature_hi, z);
    EXPECT_LT(d->gap_signature_lo, z);
  }
  EXPECT_NE(d->ToJson().find("\"noise_only_interval\""), std::string::npos);
  EXPECT_NE(d->ToText().find("noise alone reaches"), std::string::npos) << d->ToText();
}

// The leading effects (by CV score) and the base are refitted, both folds, on noisy
// copies of the data that a worker rebuilds from the task alone.
TEST(Diagnose, SimexCheckRefitsTheLeadingEffectOnNoisyCopies) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  std::vector<FitTask> runs;
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag", "time_drift"},
                                     [&](const FitTask& t, FitOutcome*) { runs.push_back(t); });
  o.refine_top = 0;
  o.simex_draws = 2;
  o.simex_top = 1;
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  std::vector<FitTask> noisy;
  for (const auto& t : runs)
    if (t.replicate > o.null_replicates) noisy.push_back(t);
  ASSERT_EQ(noisy.size(), 8u);  // 2 copies × (base + one effect) × 2 folds
  const EffectFit& lead = d->effects[0].cv_score <= d->effects[1].cv_score ? d->effects[0] : d->effects[1];
  for (const auto& t : noisy) {
    EXPECT_GE(t.spec.train_parity, 0);
    EXPECT_DOUBLE_EQ(t.null_sigma, d->noise_sigma);
    if (t.spec.has_effect) { EXPECT_EQ(InfoOf(t.spec.effect).name, lead.name); }
  }
  EXPECT_EQ(d->simex_base_mse.size(), 2u);
  for (const auto& f : d->effects) EXPECT_EQ(f.simex_mse.size(), &f == &lead ? 2u : 0u) << f.name;
  for (double m : d->simex_base_mse) EXPECT_GT(m, d->base_cv.cv_mse);  // the added noise raises the floor
  // The copies: deterministic, noisier than the data, distinct from each other.
  auto data = FitTaskData(pair, o, 0, {}, 0);
  auto c1 = FitTaskData(pair, o, o.null_replicates + 1, {}, d->noise_sigma);
  auto c1b = FitTaskData(pair, o, o.null_replicates + 1, {}, d->noise_sigma);
  auto c2 = FitTaskData(pair, o, o.null_replicates + 2, {}, d->noise_sigma);
  ASSERT_TRUE(data.ok() && c1.ok() && c1b.ok() && c2.ok());
  const Vec2 p0 = data->worms[0].frames[5].measured[0], p1 = c1->worms[0].frames[5].measured[0];
  EXPECT_NE(p0, p1);
  EXPECT_EQ(p1, c1b->worms[0].frames[5].measured[0]);
  EXPECT_NE(p1, c2->worms[0].frames[5].measured[0]);
  EXPECT_FALSE(FitTaskData(pair, o, o.null_replicates + 3, {}, d->noise_sigma).ok());
}

// When the check's fits from a refined effect's own fit fail (a copy that cannot be
// simulated from it), the check falls back to the base-centred fits instead of failing
// the diagnosis.
TEST(Diagnose, SimexCheckFallsBackToTheBaseCentredFits) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag", "time_drift"}, [](const FitTask&, FitOutcome*) {});
  o.refine_top = 1;
  o.simex_draws = 2;
  o.simex_top = 2;
  auto inner = o.run_fits;
  int refused = 0;
  o.run_fits = [&](const std::vector<FitTask>& tasks) -> Result<std::vector<FitOutcome>> {
    // The check's first batch: 2 copies × (base + 2 effects + the refined one's own) × 2 folds.
    const bool copies = std::all_of(tasks.begin(), tasks.end(),
                                    [&](const FitTask& t) { return t.replicate > o.null_replicates; });
    if (copies && tasks.size() == 16) {
      ++refused;
      return Status::FailedPrecondition("the fit found no set that could be simulated");
    }
    return inner(tasks);
  };
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_EQ(refused, 1);
  for (const auto& f : d->effects) {
    EXPECT_EQ(f.simex_mse.size(), 2u) << f.name;
    EXPECT_TRUE(f.simex_own_mse.empty()) << f.name;
  }
  EXPECT_EQ(d->simex_base_mse.size(), 2u);
}

// A refined effect is refitted on the copies from its own fit as well (its folds start
// from and are held near that fit, as on the data).
TEST(Diagnose, SimexCheckRefitsARefinedEffectFromItsOwnFitToo) {
  const auto pair = Pair(EffectParams{}, 0.002, 31, 40, 1.6);
  std::vector<FitTask> runs;
  DiagnoseOptions o = QuickDiagnosis(pair, {"lag", "time_drift"},
                                     [&](const FitTask& t, FitOutcome*) { runs.push_back(t); });
  o.refine_top = 1;
  o.simex_draws = 2;
  o.simex_top = 2;
  auto d = RunDiagnosis(pair, {"a", "b"}, o);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  const EffectFit& refined = d->effects[0].refined ? d->effects[0] : d->effects[1];
  ASSERT_TRUE(refined.refined);
  std::vector<FitTask> own;
  int noisy = 0;
  for (const auto& t : runs)
    if (t.replicate > o.null_replicates) {
      ++noisy;
      if (t.spec.has_effect && t.spec.start.mu_n == refined.coef.mu_n) own.push_back(t);
    }
  EXPECT_EQ(noisy, 16);  // 2 copies × (base + 2 effects + the refined one's own) × 2 folds
  ASSERT_EQ(own.size(), 4u);
  for (const auto& t : own) {
    EXPECT_EQ(InfoOf(t.spec.effect).name, refined.name);
    EXPECT_EQ(t.spec.effect_starts, std::vector<std::vector<double>>{refined.params});
    EXPECT_DOUBLE_EQ(t.spec.prior.eta_t, refined.coef.eta_t);
  }
  for (const auto& f : d->effects) {
    EXPECT_EQ(f.simex_mse.size(), 2u) << f.name;
    EXPECT_EQ(f.simex_own_mse.size(), &f == &refined ? 2u : 0u) << f.name;
  }
}

}  // namespace
}  // namespace wormdrag::diagnose
