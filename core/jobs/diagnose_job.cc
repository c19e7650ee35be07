#include "core/jobs/diagnose_job.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace wormdrag {

using diagnose::DiagnoseOptions;
using diagnose::FitOutcome;
using diagnose::FitTask;
using nlohmann::json;

namespace {

json CoefJson(const Coefficients& c) { return json::array({c.mu_n, c.mu_t, c.eta_n, c.eta_t}); }
Coefficients CoefFrom(const json& j) {
  const auto v = j.get<std::vector<double>>();
  if (v.size() != 4) throw std::runtime_error("coefficients need 4 values");
  return {v[0], v[1], v[2], v[3]};
}

}  // namespace

std::string DiagnoseOptionsToJson(const DiagnoseOptions& o) {
  json j;
  j["points"] = o.points;
  j["t_max"] = o.t_max;
  j["eps"] = o.epsilon;
  j["substeps"] = o.substeps;
  j["fit_hz"] = o.fit_hz;
  j["base_iterations"] = o.base_iterations;
  j["lowpass_hz"] = o.lowpass_hz;
  j["interpolate_gaps"] = o.interpolate_gaps;
  j["blocks"] = o.blocks;
  j["null_replicates"] = o.null_replicates;
  j["noise_sigma"] = o.noise_sigma;
  j["effects"] = o.effects;
  j["base_grid"] = o.base_grid;
  j["base_multistart"] = o.base_multistart;
  j["cv_ridge"] = o.cv_ridge;
  j["refine_top"] = o.refine_top;
  j["start"] = CoefJson(o.start);
  j["grg_iterations"] = o.grg_iterations;
  j["seed"] = o.seed;
  j["penalty_per_param"] = o.penalty_per_param;
  j["min_improvement"] = o.min_improvement;
  j["null_z"] = o.null_z;
  j["tie_fraction"] = o.tie_fraction;
  j["explained_share"] = o.explained_share;
  j["excess_ratio"] = o.excess_ratio;
  j["effect_gap_ratio"] = o.effect_gap_ratio;
  j["null_mean_ratio"] = o.null_mean_ratio;
  j["require_shrink_interval"] = o.require_shrink_interval;
  j["nested_fallback"] = o.nested_fallback;
  j["null_gain_vs_truth"] = o.null_gain_vs_truth;
  j["pooled_null_sd"] = o.pooled_null_sd;
  j["simex_draws"] = o.simex_draws;
  j["simex_top"] = o.simex_top;
  j["simex_warm_start"] = o.simex_warm_start;
  j["simex_weight"] = o.simex_weight;
  j["simex_min_keep"] = o.simex_min_keep;
  j["simex_explained_residual"] = o.simex_explained_residual;
  j["score_refined_fit"] = o.score_refined_fit;
  return j.dump();  // keys sorted: canonical
}

Result<DiagnoseOptions> DiagnoseOptionsFromJson(const std::string& text) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return Status::InvalidArgument("diagnosis options: not a JSON object");
  DiagnoseOptions o;
  try {
    o.points = j.value("points", o.points);
    o.t_max = j.value("t_max", o.t_max);
    o.epsilon = j.value("eps", o.epsilon);
    o.substeps = j.value("substeps", o.substeps);
    o.fit_hz = j.value("fit_hz", o.fit_hz);
    o.base_iterations = j.value("base_iterations", o.base_iterations);
    o.lowpass_hz = j.value("lowpass_hz", o.lowpass_hz);
    o.interpolate_gaps = j.value("interpolate_gaps", o.interpolate_gaps);
    o.blocks = j.value("blocks", o.blocks);
    o.null_replicates = j.value("null_replicates", o.null_replicates);
    o.noise_sigma = j.value("noise_sigma", o.noise_sigma);
    o.effects = j.value("effects", o.effects);
    o.base_grid = j.value("base_grid", o.base_grid);
    o.base_multistart = j.value("base_multistart", o.base_multistart);
    o.cv_ridge = j.value("cv_ridge", o.cv_ridge);
    o.refine_top = j.value("refine_top", o.refine_top);
    if (j.contains("start")) o.start = CoefFrom(j["start"]);
    o.grg_iterations = j.value("grg_iterations", o.grg_iterations);
    o.seed = j.value("seed", o.seed);
    o.penalty_per_param = j.value("penalty_per_param", o.penalty_per_param);
    o.min_improvement = j.value("min_improvement", o.min_improvement);
    o.null_z = j.value("null_z", o.null_z);
    o.tie_fraction = j.value("tie_fraction", o.tie_fraction);
    o.explained_share = j.value("explained_share", o.explained_share);
    o.excess_ratio = j.value("excess_ratio", o.excess_ratio);
    o.effect_gap_ratio = j.value("effect_gap_ratio", o.effect_gap_ratio);
    o.null_mean_ratio = j.value("null_mean_ratio", o.null_mean_ratio);
    o.require_shrink_interval = j.value("require_shrink_interval", o.require_shrink_interval);
    o.nested_fallback = j.value("nested_fallback", o.nested_fallback);
    o.null_gain_vs_truth = j.value("null_gain_vs_truth", o.null_gain_vs_truth);
    o.pooled_null_sd = j.value("pooled_null_sd", o.pooled_null_sd);
    o.simex_draws = j.value("simex_draws", o.simex_draws);
    o.simex_top = j.value("simex_top", o.simex_top);
    o.simex_warm_start = j.value("simex_warm_start", o.simex_warm_start);
    o.simex_weight = j.value("simex_weight", o.simex_weight);
    o.simex_min_keep = j.value("simex_min_keep", o.simex_min_keep);
    o.simex_explained_residual = j.value("simex_explained_residual", o.simex_explained_residual);
    o.score_refined_fit = j.value("score_refined_fit", o.score_refined_fit);
  } catch (const std::exception& ex) {
    return Status::InvalidArgument(std::string("diagnosis options: ") + ex.what());
  }
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  return o;
}

std::string FitTaskToJson(const FitTask& t) {
  const diagnose::FitSpec& s = t.spec;
  json j;
  j["replicate"] = t.replicate;
  j["null_base"] = CoefJson(t.null_base);
  j["null_sigma"] = t.null_sigma;
  j["effect"] = s.has_effect ? diagnose::InfoOf(s.effect).name : "";
  j["effect_starts"] = s.effect_starts;
  j["start"] = CoefJson(s.start);
  j["extra_starts"] = json::array();
  for (const auto& c : s.extra_starts) j["extra_starts"].push_back(CoefJson(c));
  j["prior"] = CoefJson(s.prior);
  j["prior_weight"] = s.prior_weight;
  j["blocked"] = s.blocked;
  j["train_parity"] = s.train_parity;
  j["iterations"] = s.iterations;
  j["eps"] = s.epsilon;
  j["forward_differences"] = s.forward_differences;
  j["per_worm"] = s.per_worm;
  return j.dump();
}

Result<FitTask> FitTaskFromJson(const std::string& text) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return Status::InvalidArgument("fit task: not a JSON object");
  FitTask t;
  try {
    t.replicate = j.at("replicate").get<int>();
    t.null_base = CoefFrom(j.at("null_base"));
    t.null_sigma = j.at("null_sigma").get<double>();
    const std::string effect = j.at("effect").get<std::string>();
    t.spec.has_effect = !effect.empty();
    if (t.spec.has_effect) {
      auto e = diagnose::ParseEffectName(effect);
      if (!e.ok()) return e.status().Annotate("fit task");
      t.spec.effect = *e;
    }
    t.spec.effect_starts = j.at("effect_starts").get<std::vector<std::vector<double>>>();
    t.spec.start = CoefFrom(j.at("start"));
    for (const auto& c : j.value("extra_starts", json::array())) t.spec.extra_starts.push_back(CoefFrom(c));
    if (j.contains("prior")) t.spec.prior = CoefFrom(j.at("prior"));
    t.spec.prior_weight = j.value("prior_weight", 0.0);
    t.spec.blocked = j.at("blocked").get<bool>();
    t.spec.train_parity = j.at("train_parity").get<int>();
    t.spec.iterations = j.at("iterations").get<int>();
    t.spec.epsilon = j.at("eps").get<double>();
    t.spec.forward_differences = j.at("forward_differences").get<bool>();
    t.spec.per_worm = j.value("per_worm", false);  // absent in tasks written before it existed
  } catch (const std::exception& ex) {
    return Status::InvalidArgument(std::string("fit task: ") + ex.what());
  }
  if (t.spec.has_effect) {
    // A per-worm fit's start gives one set for both worms or both worms' values.
    const size_t ne = diagnose::InfoOf(t.spec.effect).params.size();
    for (const auto& s : t.spec.effect_starts)
      if (s.size() != ne && !(t.spec.per_worm && s.size() == 2 * ne))
        return Status::InvalidArgument("fit task: an effect start has the wrong number of parameters");
  }
  if (t.spec.train_parity < -1 || t.spec.train_parity > 1 || t.spec.iterations < 1 || !(t.spec.epsilon > 0))
    return Status::InvalidArgument("fit task: parity, iterations or eps out of range");
  if (!(t.spec.prior_weight >= 0) || !std::isfinite(t.spec.prior_weight))
    return Status::InvalidArgument("fit task: prior_weight must be >= 0");
  return t;
}

std::vector<double> FitOutcomeToValues(const FitOutcome& f) {
  std::vector<double> v = {f.coef.mu_n, f.coef.mu_t, f.coef.eta_n, f.coef.eta_t, f.train_mse,
                           static_cast<double>(f.evaluations)};
  v.insert(v.end(), f.params.begin(), f.params.end());
  return v;
}

Result<FitOutcome> FitOutcomeFromValues(const std::vector<double>& v, const FitTask& task) {
  const size_t ne = task.spec.has_effect ? diagnose::InfoOf(task.spec.effect).params.size() : 0;
  const size_t np = task.spec.per_worm ? 2 * ne : ne;  // per_worm: worm 1's, then worm 2's
  if (v.size() != 6 + np)
    return Status::InvalidArgument("fit result: " + std::to_string(v.size()) + " values, expected " +
                                   std::to_string(6 + np));
  FitOutcome f;
  f.coef = {v[0], v[1], v[2], v[3]};
  f.train_mse = v[4];
  f.evaluations = static_cast<long>(v[5]);
  f.params.assign(v.begin() + 6, v.end());
  if (task.spec.has_effect) {
    diagnose::SetParams(&f.effects, task.spec.effect, {f.params.begin(), f.params.begin() + ne});
    if (task.spec.per_worm)
      diagnose::SetParams(&f.second_worm_effects, task.spec.effect, {f.params.begin() + ne, f.params.end()});
  }
  return f;
}

Result<int64_t> SubmitDiagnoseJob(JobStore& store, const std::array<JobInput, 2>& inputs, const DiagnoseOptions& options) {
  WORMDRAG_RETURN_IF_ERROR(options.Validate());
  std::array<Kinematics, 2> ks;
  for (int j = 0; j < 2; ++j) {
    auto k = ParseKinematics(inputs[j].content, inputs[j].name);
    if (!k.ok()) return k.status();
    ks[j] = std::move(*k);
  }
  // Refuse what the diagnosis would refuse (too few frames for the blocks, …) now.
  auto data = diagnose::PrepareForDiagnosis(ks, options);
  if (!data.ok()) return data.status();
  JobRecord job;
  job.kind = "diagnose";
  const std::array<DatasetRecord, 2> ds = DatasetRecords(inputs, &job);
  job.options_json = DiagnoseOptionsToJson(options);
  job.eval_key = Sha256Hex("diagnose|" + job.dataset_hashes[0] + "|" + job.dataset_hashes[1] + "|" + job.options_json);
  return store.CreateJob(job, ds);
}

Result<std::array<Kinematics, 2>> LoadRecordings(JobStore& store, const JobRecord& job) {
  auto in = LoadInputs(store, job);
  if (!in.ok()) return in.status();
  std::array<Kinematics, 2> ks;
  for (int j = 0; j < 2; ++j) {
    auto k = ParseKinematics((*in)[j].content, (*in)[j].name);
    if (!k.ok()) return k.status();
    ks[j] = std::move(*k);
  }
  return ks;
}

Status RunDiagnoseJob(JobStore& store, int64_t job_id, const diagnose::FitRunner& run_fits, int threads,
                      const JobHooks& hooks) {
  auto job = store.GetJob(job_id);
  if (!job.ok()) return job.status();
  if (job->kind != "diagnose") return Status::InvalidArgument("job " + std::to_string(job_id) + " is not a diagnosis");
  if (job->state == JobState::kDone) return Status::Ok();
  if (job->state == JobState::kCancelled) return Status::Cancelled("job " + std::to_string(job_id) + " was cancelled");
  JobRun run(store, job_id, hooks);
  auto options = DiagnoseOptionsFromJson(job->options_json);
  if (!options.ok()) return run.Fail(options.status());
  auto ks = LoadRecordings(store, *job);
  if (!ks.ok()) return run.Fail(ks.status());
  WORMDRAG_RETURN_IF_ERROR(store.SetState(job_id, JobState::kRunning));
  DiagnoseOptions o = *options;
  o.threads = threads;
  o.run_fits = run_fits;
  o.progress = [&](const std::string& stage, double fraction) {
    // Fractions as counts out of 1000 (the store and the wire speak done/total).
    run.Progress(stage, std::llround(1000 * fraction), 1000, 0);
  };
  o.cancelled = [&]() { return run.Cancelled(); };
  auto d = diagnose::RunDiagnosis(*ks, job->dataset_names, o);
  if (!d.ok()) return run.Fail(d.status());
  return store.SetResult(job_id, d->ToJson());
}

}  // namespace wormdrag
