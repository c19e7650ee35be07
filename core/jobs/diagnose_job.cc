#include "core/jobs/diagnose_job.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/diagnose/diagnosis.h"

namespace wormdrag {

using diagnose::DiagnoseOptions;
using diagnose::FitOutcome;
using diagnose::FitTask;
using nlohmann::json;

namespace {

json CoefJson(const Coefficients& c) {
  return json::array({c.mu_n, c.mu_t, c.eta_n, c.eta_t});
}
Coefficients CoefFrom(const json& j) {
  const auto v = j.get<std::vector<double>>();
  if (v.size() != 4) throw std::runtime_error("coefficients need 4 values");
  return {v[0], v[1], v[2], v[3]};
}

// Every option but the start coefficients, by its JSON key: one list read by both
// directions, so a new option cannot be written and then forgotten on the way back.
template <class Options, class Visit>
void ForEachOption(Options& o, Visit&& f) {
  f("points", o.points);
  f("t_max", o.t_max);
  f("eps", o.epsilon);
  f("substeps", o.substeps);
  f("fit_hz", o.fit_hz);
  f("base_iterations", o.base_iterations);
  f("lowpass_hz", o.lowpass_hz);
  f("interpolate_gaps", o.interpolate_gaps);
  f("blocks", o.blocks);
  f("null_replicates", o.null_replicates);
  f("noise_sigma", o.noise_sigma);
  f("effects", o.effects);
  f("base_grid", o.base_grid);
  f("base_multistart", o.base_multistart);
  f("cv_ridge", o.cv_ridge);
  f("refine_top", o.refine_top);
  f("grg_iterations", o.grg_iterations);
  f("seed", o.seed);
  f("penalty_per_param", o.penalty_per_param);
  f("min_improvement", o.min_improvement);
  f("tie_fraction", o.tie_fraction);
  f("explained_share", o.explained_share);
  f("false_alarm_rate", o.false_alarm_rate);
  f("require_shrink_interval", o.require_shrink_interval);
  f("nested_fallback", o.nested_fallback);
  f("simex_draws", o.simex_draws);
  f("simex_top", o.simex_top);
  f("simex_weight", o.simex_weight);
  f("simex_min_keep", o.simex_min_keep);
  f("score_refined_fit", o.score_refined_fit);
  f("require_gap_signature", o.require_gap_signature);
  f("require_estimated_params", o.require_estimated_params);
  f("clear_margin", o.clear_margin);
}

}  // namespace

std::string DiagnoseOptionsToJson(const DiagnoseOptions& o) {
  json j;
  ForEachOption(o, [&](const char* key, const auto& v) { j[key] = v; });
  j["smoothing"] = SmoothingMethodName(o.smoothing);
  j["spline_order"] = o.spline.order;
  j["start"] = CoefJson(o.start);
  return j.dump();  // keys sorted: canonical
}

Result<DiagnoseOptions> DiagnoseOptionsFromJson(const std::string& text) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return Status::InvalidArgument("diagnosis options: not a JSON object");
  DiagnoseOptions o;
  try {
    ForEachOption(o, [&](const char* key, auto& v) { v = j.value(key, v); });
    if (j.contains("start")) o.start = CoefFrom(j["start"]);
    if (j.contains("smoothing")) {
      auto m = ParseSmoothingMethod(j["smoothing"].get<std::string>());
      if (!m.ok()) return m.status().Annotate("diagnosis options");
      o.smoothing = *m;
    } else {
      o.smoothing = SmoothingMethod::kLowpass;  // stored before smoothing was a choice
    }
    o.spline.order = j.value("spline_order", o.spline.order);
  } catch (const std::exception& ex) { return Status::InvalidArgument(std::string("diagnosis options: ") + ex.what()); }
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
    t.spec.per_worm = j.value("per_worm", false);
  } catch (const std::exception& ex) { return Status::InvalidArgument(std::string("fit task: ") + ex.what()); }
  WORMDRAG_RETURN_IF_ERROR(CheckFitTask(t));
  return t;
}

Status CheckFitTask(const FitTask& t) {
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
  return Status::Ok();
}

std::vector<double> FitOutcomeToValues(const FitOutcome& f) {
  std::vector<double> v = {f.coef.mu_n,  f.coef.mu_t, f.coef.eta_n,
                           f.coef.eta_t, f.train_mse, static_cast<double>(f.evaluations)};
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

Result<int64_t> SubmitDiagnoseJob(JobStore& store, const std::array<JobInput, 2>& inputs,
                                  const DiagnoseOptions& options) {
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
