// Shared set-up of the diagnosis tests: synthetic pairs, how far two simulated paths lie
// apart, hand-made scores for Decide, and a quick diagnosis whose fits run in-process.
#pragma once

#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/diagnose/diagnosis.h"
#include "core/diagnose/synth.h"

namespace wormdrag::diagnose::test {

inline const Coefficients kTrue{0.6, 0.2, 0.006, 0.002};

// The largest distance between the two trajectories' points over every frame (mm).
inline double MaxPoseDistance(const EffectDrive& d, const EffectTrajectory& a, const EffectTrajectory& b) {
  double e = 0;
  for (int f = d.drive().first_frame(); f <= d.drive().last_frame(); ++f) {
    const Points pa = EffectPoints(d, a, f), pb = EffectPoints(d, b, f);
    for (int k = 0; k < kNumPoints; ++k) e = std::max(e, (pa[k] - pb[k]).norm());
  }
  return e;
}

inline std::array<Kinematics, 2> Pair(const EffectParams& e, double noise, uint64_t seed, double fps = 50,
                                      double dur = 2, GapPattern gaps = {}, const Coefficients& coef = kTrue) {
  std::array<Kinematics, 2> out;
  for (int j = 0; j < 2; ++j) {
    SynthSpec s;
    s.pattern = Locomotion(j + 1);
    s.coef = coef;
    s.effects = e;
    s.fps = fps;
    s.duration = dur;
    s.noise = noise;
    s.seed = seed + j;
    s.substeps = 2;
    s.gaps = gaps;
    auto r = Synthesize(s);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    out[j] = r->recording;
  }
  return out;
}

// Decide's verdict from hand-made scores: 8 held-out blocks of 10 frames each, base
// error 1 per frame; a noise-only refit gains nothing.
inline Diagnosis Scores(const std::vector<double>& effect_block_sums) {
  Diagnosis d;
  d.base_cv.block_sum.assign(8, 10.0);
  d.base_cv.block_count.assign(8, 10.0);
  d.base_cv.cv_mse = 1.0;
  // Noise-only replicates that score about as the data do: no gap beyond noise.
  d.null_base_cv_mses = {0.9, 1.0, 1.1};
  d.null_base_cv_mse = 1.0;
  d.null_base_cv_sd = 0.1;
  d.null_base_cv_e = 0.7;
  EffectFit f;
  f.name = "lag";
  f.param_names = {"delta"};
  f.params = {0.05};
  f.param_lo = {0.04};
  f.param_hi = {0.06};
  f.extra_params = 1;
  f.block_sum = effect_block_sums;
  f.block_count.assign(8, 10.0);
  double s = 0;
  for (double b : effect_block_sums) s += b;
  f.cv_mse = s / 80.0;  // the per-frame error squared is ~ the error here: only the ratio matters
  f.null_improvements = {1.0, 1.0, 1.0};
  d.effects.push_back(f);
  return d;
}

// Noise-only replicates whose held-out MSE is about `mse` (±2 %): with mse well below
// the data's base score, a gap beyond noise.
inline void NullFloor(Diagnosis* d, double mse) {
  d->null_base_cv_mses = {0.98 * mse, mse, 1.02 * mse};
  d->null_base_cv_mse = mse;
  d->null_base_cv_sd = 0.02 * mse;
}

// A quick diagnosis of `pair` (GRG base from the truth, 2 blocks, 2 replicates, few
// iterations) whose fits run here, each outcome shown to `seen` (which may alter it)
// before the diagnosis uses it.
inline DiagnoseOptions QuickDiagnosis(const std::array<Kinematics, 2>& pair, const std::vector<std::string>& effects,
                                      std::function<void(const FitTask&, FitOutcome*)> seen) {
  DiagnoseOptions o;
  o.base_grid = false;
  o.start = kTrue;
  o.base_iterations = 10;
  o.grg_iterations = 2;
  o.blocks = 2;
  o.null_replicates = 2;
  o.effects = effects;
  o.threads = 1;
  o.run_fits = [pair, prep = o, seen](const std::vector<FitTask>& tasks) -> Result<std::vector<FitOutcome>> {
    std::vector<FitOutcome> out;
    for (const auto& t : tasks) {
      auto d = FitTaskData(pair, prep, t.replicate, t.null_base, t.null_sigma);
      if (!d.ok()) return d.status();
      auto f = FitModel(*d, t.spec);
      if (!f.ok()) return f.status();
      seen(t, &*f);
      out.push_back(*f);
    }
    return out;
  };
  return o;
}

}  // namespace wormdrag::diagnose::test
