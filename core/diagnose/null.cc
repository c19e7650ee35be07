// The noise-only replicates and the SIMEX check: recordings simulated from the base fit
// plus tracking noise (the null), and copies of the data with tracking noise added, each
// put through the same pipeline as the data.
#include <algorithm>
#include <map>
#include <tuple>

#include "core/diagnose/internal/stages.h"
#include "core/diagnose/synth.h"
#include "core/sim/cubic_spline.h"

namespace wormdrag::diagnose {

// A noise-free recording of the base model `c` on w's joint angles, at w's full frame
// rate and with its missing frames, plus tracking noise σ: what the null replicates
// put through the pipeline. With a subsampled fit the pose is simulated at the fit's
// knots and interpolated (cubic spline) to every frame; the shape is each frame's own.
Result<Kinematics> NullRecording(const EffectRecording& w, const Coefficients& c, double eps, double sigma,
                                 uint64_t seed) {
  const EffectTrajectory t = internal::Run(w, c, {}, false, eps);
  if (!t.ok()) return Status::Internal("the null simulation did not converge");
  const ShapeDrive& sd = w.drive->drive();
  Kinematics k;
  if (w.source_frames.empty()) {
    k = w.kinematics;
    for (int f = 0; f < static_cast<int>(k.frames.size()); ++f) {
      if (f < sd.first_frame() || f > sd.last_frame()) {
        k.frames[f].valid = false;
        continue;
      }
      if (!k.frames[f].valid) continue;
      k.frames[f].p = EffectPoints(*w.drive, t, f);
      k.frames[f].arc_length = sd.body().length;
    }
  } else {
    k = w.full;
    std::vector<double> ts, xs, ys, qs;
    for (int f = sd.first_frame(); f <= sd.last_frame(); ++f) {
      const Pose& g = t.poses[f - t.first_frame];
      ts.push_back(w.kinematics.frames[f].t);
      xs.push_back(g.x);
      ys.push_back(g.y);
      qs.push_back(g.q0);
    }
    const CubicSpline sx(ts, xs), sy(ts, ys), sq(ts, qs);
    const double l = sd.body().link_length();
    for (auto& fr : k.frames) {
      if (fr.t < ts.front() - 1e-12 || fr.t > ts.back() + 1e-12) {
        fr.valid = false;
        continue;
      }
      if (!fr.valid) continue;
      Pose g;
      double dummy;
      sx.Evaluate(fr.t, &g.x, &dummy);
      sy.Evaluate(fr.t, &g.y, &dummy);
      sq.Evaluate(fr.t, &g.q0, &dummy);
      fr.p = LabPoints(g, ShapeOf(fr.p), l);
      fr.arc_length = sd.body().length;
    }
  }
  AddTrackingNoise(&k, sigma, seed);
  return k;
}

namespace internal {

// Noise-only replicate r ≥ 1: the base fit simulated on the truth's joint angles
// (NullTruth), with the recordings' missing frames and Gaussian tracking noise, through
// the same preprocessing (docs/decisions/0014-null-replicates.md, 0038).
Result<EffectData> NullReplicate(const EffectData& data, const DiagnoseOptions& o, const Coefficients& base,
                                 double sigma, int r) {
  std::array<Kinematics, 2> ks;
  std::array<std::string, 2> names;
  for (int j = 0; j < 2; ++j) {
    auto k = NullRecording(data.worms[j], base, o.epsilon, sigma, o.seed + 1000 * (r - 1) + j);
    if (!k.ok()) return k.status();
    ks[j] = std::move(*k);
    names[j] = "null replicate " + std::to_string(r) + " worm " + std::to_string(j + 1);
  }
  return PreparePair(ks, 1e9, o, names);
}

// The SIMEX check's noisy copy d of the recordings: tracking noise σ added to every
// valid frame of the raw recordings, then prepared as the data is.
Result<EffectData> SimexCopy(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o, double sigma,
                             int d) {
  std::array<Kinematics, 2> noisy = recordings;
  for (int j = 0; j < 2; ++j) AddTrackingNoise(&noisy[j], sigma, o.seed + 500000 + 1000 * d + j);
  return PrepareForDiagnosis(noisy, o);
}

}  // namespace internal

Result<EffectData> FitTaskData(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o, int replicate,
                               const Coefficients& null_base, double null_sigma) {
  if (replicate < 0 || replicate > o.null_replicates + o.simex_draws)
    return Status::InvalidArgument("fit task replicate " + std::to_string(replicate) + " outside 0.." +
                                   std::to_string(o.null_replicates + o.simex_draws));
  if (replicate > o.null_replicates)
    return internal::SimexCopy(recordings, o, null_sigma, replicate - o.null_replicates - 1);
  auto data = PrepareForDiagnosis(recordings, o);
  if (!data.ok() || replicate == 0) return data;
  auto truth = NullTruth(recordings, *data, o);
  if (!truth.ok()) return truth.status();
  return internal::NullReplicate(*truth, o, null_base, null_sigma, replicate);
}

namespace internal {

Status MakeNullReplicates(DiagnosisRun* run) {
  if (run->o.null_replicates < 1) return Status::Ok();
  auto truth = NullTruth(run->recordings, run->data, run->o, kMaxGaitExcess, &run->out.null_gait_excess);
  if (!truth.ok()) return truth.status();
  // Cheap: one simulation each.
  for (int r = 1; r <= run->o.null_replicates; ++r) {
    auto nd = NullReplicate(*truth, run->o, run->cv_base, run->out.noise_sigma, r);
    if (!nd.ok()) return nd.status();
    run->null_data.push_back(std::move(*nd));
  }
  for (const auto& nd : run->null_data) run->replicate_data.push_back(&nd);
  return Status::Ok();
}

namespace {

// The SIMEX check's fits on every copy: the base's folds, each examined effect's
// base-centred folds, and (own_folds) a refined effect's folds centred on its own fit, as
// on the data; scored into run->out.simex_base_mse, run->simex_mse and run->simex_own_mse.
Status RunSimexFits(DiagnosisRun* run, const std::vector<int>& simex_effects, bool own_folds) {
  const DiagnoseOptions& o = run->o;
  const std::vector<Effect>& tested = run->tested;
  const std::vector<EffectData>& simex_data = run->simex_data;
  struct SimexSlot {
    int draw, model;  // model: -1 base, else index into `tested`
    bool own;
  };
  std::vector<FitTask> simex_tasks;
  std::vector<SimexSlot> simex_slots;
  for (int d = 0; d < static_cast<int>(simex_data.size()); ++d) {
    auto add = [&](int model, bool own_fit, const FitSpec& spec) {
      FitTask t;
      t.replicate = o.null_replicates + 1 + d;
      t.null_sigma = run->out.noise_sigma;
      t.spec = spec;
      simex_tasks.push_back(t);
      simex_slots.push_back({d, model, own_fit});
    };
    for (int parity = 0; parity < 2; ++parity)
      add(-1, false, CvSpec(false, Effect::kBodyGradient, run->cv_base, run->ridge_mm, parity, o));
    for (int i : simex_effects) {
      for (int parity = 0; parity < 2; ++parity)
        add(i, false, CvSpec(true, tested[i], run->cv_base, run->ridge_mm, parity, o));
      if (!own_folds || !o.score_refined_fit || !run->own[i]) continue;
      for (int parity = 0; parity < 2; ++parity) {
        FitSpec fs = CvSpec(true, tested[i], run->full[i].coef, run->ridge_mm, parity, o);
        fs.effect_starts = {run->full[i].params};
        add(i, true, fs);
      }
    }
  }
  if (simex_tasks.empty()) return Status::Ok();
  run->StartFits("SIMEX check", static_cast<int>(simex_tasks.size()));
  auto fitted = run->RunFits(simex_tasks);
  if (!fitted.ok()) return fitted.status();
  if (fitted->size() != simex_tasks.size()) return Status::Internal("the fit runner returned the wrong number of fits");
  std::map<std::tuple<int, int, bool>, std::array<const FitOutcome*, 2>> pairs;
  for (size_t k = 0; k < simex_slots.size(); ++k) {
    const SimexSlot& sl = simex_slots[k];
    pairs[{sl.draw, sl.model, sl.own}][simex_tasks[k].spec.train_parity] = &(*fitted)[k];
  }
  run->out.simex_base_mse.clear();
  for (auto* v : {&run->simex_mse, &run->simex_own_mse})
    for (auto& m : *v) m.clear();
  for (int d = 0; d < static_cast<int>(simex_data.size()); ++d) {
    const auto& base = pairs.at({d, -1, false});
    run->out.simex_base_mse.push_back(AssembleCv(simex_data[d], base, o.epsilon).mse);
    for (int i : simex_effects) {
      // As on the data: a base-centred fold fit the optimiser lost is replaced by the
      // base's (nested_fallback).
      const auto& f = pairs.at({d, i, false});
      std::array<FitOutcome, 2> folds = {*f[0], *f[1]};
      for (int parity = 0; parity < 2; ++parity)
        if (o.nested_fallback && LostToTheBase(folds[parity], *base[parity]))
          folds[parity] = BaseWithNeutralEffect(*base[parity], tested[i]);
      run->simex_mse[i].push_back(AssembleCv(simex_data[d], {&folds[0], &folds[1]}, o.epsilon).mse);
      if (const auto own_fit = pairs.find({d, i, true}); own_fit != pairs.end())
        run->simex_own_mse[i].push_back(AssembleCv(simex_data[d], own_fit->second, o.epsilon).mse);
    }
  }
  return Status::Ok();
}

}  // namespace

Status CheckSimex(DiagnosisRun* run) {
  const DiagnoseOptions& o = run->o;
  // The effects that lead once the own refits are counted as Decide counts them: an
  // effect found only by its own fit must not win unexamined.
  const std::vector<int> leading = run->Rank(run->ranked, &run->own);
  const std::vector<int> simex_effects(leading.begin(),
                                       leading.begin() + std::min<size_t>(leading.size(), o.simex_top));
  if (!simex_effects.empty())
    for (int d = 0; d < o.simex_draws; ++d) {
      auto sd = SimexCopy(run->recordings, o, run->out.noise_sigma, d);
      if (!sd.ok()) return sd.status().Annotate("SIMEX copy " + std::to_string(d + 1));
      run->simex_data.push_back(std::move(*sd));
    }
  for (const auto& sd : run->simex_data) run->replicate_data.push_back(&sd);
  run->simex_mse.assign(run->tested.size(), {});
  run->simex_own_mse.assign(run->tested.size(), {});
  // The own-centred fits start where a copy may not simulate (a benchmark stretch pair's
  // did not): then the check falls back to the base-centred fits alone, and fails only if
  // those fail.
  Status st = RunSimexFits(run, simex_effects, true);
  if (!st.ok() && st.code() != Status::Code::kCancelled) st = RunSimexFits(run, simex_effects, false);
  if (!st.ok()) return st.Annotate("SIMEX check");
  if (run->Cancelled()) return Status::Cancelled("diagnosis cancelled");
  return Status::Ok();
}

}  // namespace internal
}  // namespace wormdrag::diagnose
