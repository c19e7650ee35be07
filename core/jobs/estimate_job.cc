#include "core/jobs/estimate_job.h"

#include "core/jobs/bootstrap_run.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace wormdrag {

// Canonical key text, not a document for reading: the job store compares it as text to
// reuse jobs, so its bytes (%.17g numbers, this key order) are fixed.
std::string JobOptions::ToJson() const {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                ",\"lowpass_hz\":%.17g,\"causal_filter\":%s,\"smoothing\":\"%s\",\"spline_order\":%d,"
                "\"bootstrap_replicates\":%d,\"bootstrap_level\":%.17g,\"bootstrap_seed\":%llu}",
                lowpass_hz, causal_filter ? "true" : "false", SmoothingMethodName(smoothing), spline.order,
                bootstrap.replicates, bootstrap.level, static_cast<unsigned long long>(bootstrap.seed));
  std::string s = estimate.ToJson();
  s.pop_back();  // the closing brace
  return s + buf;
}

namespace {

// A field the options cannot hold (an integer out of range, or not whole): thrown
// inside JobOptionsFromJson only and turned into its InvalidArgument there.
struct BadField : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// An integer field, checked before conversion: a float or an out-of-range value would
// otherwise be converted with undefined behaviour.
template <typename T>
T IntegerValue(const nlohmann::json& v, const std::string& key) {
  // nlohmann keeps a non-negative integer literal as unsigned, a negative one as signed.
  if (v.is_number_unsigned()) {
    if (v.get<uint64_t>() <= static_cast<uint64_t>(std::numeric_limits<T>::max()))
      return static_cast<T>(v.get<uint64_t>());
  } else if (v.is_number_integer()) {
    if constexpr (std::numeric_limits<T>::is_signed) {
      const int64_t i = v.get<int64_t>();
      if (i >= std::numeric_limits<T>::min() && i <= std::numeric_limits<T>::max()) return static_cast<T>(i);
    }
  }
  throw BadField("field '" + key + "': " + v.dump() + " is not an integer in range");
}
template <typename T>
T Integer(const nlohmann::json& j, const char* key) {
  return IntegerValue<T>(j.at(key), key);
}

// A real field. -0 becomes +0: the canonical text writes -0 as "-0", which reads back as
// the integer 0, so a stored -0 would not survive its own round trip.
double Real(const nlohmann::json& j, const char* key) {
  return j.at(key).get<double>() + 0.0;
}
double RealOr(const nlohmann::json& j, const char* key, double fallback) {
  return j.contains(key) ? Real(j, key) : fallback;
}

}  // namespace

Result<JobOptions> JobOptionsFromJson(const std::string& text, OptionsUse use) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return Status::InvalidArgument("job options: not a JSON object");
  JobOptions o;
  EstimateOptions& e = o.estimate;
  try {
    const auto& ev = j.at("eval");
    e.eval.points.clear();
    for (const auto& p : ev.at("points")) e.eval.points.push_back(IntegerValue<int>(p, "points"));
    e.eval.t_max = Real(ev, "t_max");
    auto solver = ParseSolver(ev.at("solver").get<std::string>());
    if (!solver.ok()) return solver.status();
    e.eval.sim.solver = *solver;
    e.eval.sim.epsilon = Real(ev, "eps");
    e.eval.sim.velocity_tolerance = Real(ev, "tolerance");
    e.eval.substeps = Integer<int>(ev, "substeps");
    // Absent in jobs stored before the knot rate existed; they name their step explicitly.
    e.eval.knot_rate = RealOr(ev, "knot_rate", EvaluationOptions().knot_rate);
    e.eval.restart_after_gaps = ev.at("restart_after_gaps").get<bool>();
    e.eval.restart_every = RealOr(ev, "restart_every", 0.0);
    e.screening_substeps = Integer<int>(j, "screening_substeps");
    e.search.n_max = Integer<int>(j, "n_max");
    e.search.d_mu = Real(j, "d_mu");
    e.search.d_eta = Real(j, "d_eta");
    e.search.d1 = Real(j, "d1");
    e.search.d2 = Real(j, "d2");
    auto m = ParsePhase3Method(j.at("phase3").get<std::string>());
    if (!m.ok()) return m.status();
    e.phase3.method = *m;
    e.phase3.fix_scale = j.at("fix_scale").get<bool>();
    e.phase3.grg.max_iterations = Integer<int>(j, "grg_max_iterations");
    e.phase3.grg.gradient_tolerance = Real(j, "grg_gradient_tolerance");
    e.phase3.grg.fd_step = Real(j, "fd_step");
    e.phase3.max_evaluations = Integer<int>(j, "max_evaluations");
    // Absent in jobs stored before early abandoning existed; it never changes survivors.
    e.search.abandon = j.value("abandon", true);
    o.lowpass_hz = Real(j, "lowpass_hz");
    o.causal_filter = j.at("causal_filter").get<bool>();
    // Jobs stored before smoothing was a choice name only their low-pass (0 = none).
    if (j.contains("smoothing")) {
      auto m = ParseSmoothingMethod(j.at("smoothing").get<std::string>());
      if (!m.ok()) return m.status();
      o.smoothing = *m;
      o.spline.order = Integer<int>(j, "spline_order");
      o.bootstrap.replicates = Integer<int>(j, "bootstrap_replicates");
      o.bootstrap.level = Real(j, "bootstrap_level");
      o.bootstrap.seed = Integer<uint64_t>(j, "bootstrap_seed");
    } else {
      o.bootstrap.replicates = 0;
      o.smoothing = o.lowpass_hz > 0 ? SmoothingMethod::kLowpass : SmoothingMethod::kNone;
    }
  } catch (const nlohmann::json::exception& ex) {
    return Status::InvalidArgument(std::string("job options: ") + ex.what());
  } catch (const BadField& ex) { return Status::InvalidArgument(std::string("job options: ") + ex.what()); }
  WORMDRAG_RETURN_IF_ERROR(e.Validate());
  WORMDRAG_RETURN_IF_ERROR(o.spline.Validate());
  if (use == OptionsUse::kRun) WORMDRAG_RETURN_IF_ERROR(o.bootstrap.Validate());
  if (!(o.lowpass_hz >= 0)) return Status::InvalidArgument("lowpass cut-off must be >= 0 Hz");
  return o;
}

std::string EvalKey(const std::array<std::string, 2>& hashes, const JobOptions& o) {
  // A low-pass job's key has the form it had before smoothing was a choice, so stored
  // evaluations of such jobs stay reusable.
  const double lowpass = o.smoothing == SmoothingMethod::kLowpass ? o.lowpass_hz : 0.0;
  char buf[160];
  std::snprintf(buf, sizeof buf, "|lowpass=%.17g|causal=%d|screening=%d", lowpass,
                lowpass > 0 && o.causal_filter ? 1 : 0, o.estimate.screening_substeps);
  std::string key = hashes[0] + "|" + hashes[1] + "|" + o.estimate.eval.ToJson() + buf;
  if (o.smoothing == SmoothingMethod::kAuto) key += "|smoothing=auto|order=" + std::to_string(o.spline.order);
  return Sha256Hex(key);
}

Result<Kinematics> SmoothRecording(const std::string& name, const Kinematics& k, const JobOptions& options,
                                   SmoothingReport* report) {
  SmoothingReport local;
  SmoothingReport* r = report ? report : &local;
  Result<Kinematics> out = k;
  switch (options.smoothing) {
    case SmoothingMethod::kAuto:
      out = SmoothShapesAuto(k, options.spline, r);
      break;
    case SmoothingMethod::kLowpass: {
      if (!(options.lowpass_hz > 0)) return Status::InvalidArgument("smoothing lowpass needs a cut-off > 0 Hz");
      AngleFilterOptions f;
      f.cutoff_hz = options.lowpass_hz;
      f.zero_phase = !options.causal_filter;
      out = FilterJointAngles(k, f, r);
      break;
    }
    case SmoothingMethod::kNone:
      r->method = "none";
      r->noise_mm = TrackingNoiseByDifferences(k);
      r->noise_percent_bl = k.BodyLength() > 0 ? 100 * r->noise_mm / k.BodyLength() : 0;
      break;
  }
  if (!out.ok()) return out.status().Annotate(name);
  return out;
}

Result<Kinematics> PrepareRecording(const std::string& name, const std::string& content, const JobOptions& options,
                                    SmoothingReport* report) {
  auto k = ParseKinematics(content, name, {options.estimate.eval.t_max});
  if (!k.ok()) return k.status();
  if (k->NumValid() == 0) return Status::InvalidArgument(name + ": no valid frame (every frame is missing)");
  return SmoothRecording(name, *k, options, report);
}

namespace {

// The pair's recordings are parsed, checked for the work of every evaluation in `evals`
// and smoothed once; a paired path is then made per evaluation (evals[0] first). The
// evaluations share t_max (a screening evaluation differs only in its step).
Result<std::vector<std::shared_ptr<const PairedPath>>> BuildPairs(const std::array<JobInput, 2>& in,
                                                                  const JobOptions& o,
                                                                  const std::vector<EvaluationOptions>& evals,
                                                                  std::array<SmoothingReport, 2>* reports = nullptr) {
  std::array<Kinematics, 2> k;
  for (int j = 0; j < 2; ++j) {
    // A recording with no frame to analyse within t_max is refused while it is read.
    auto parsed = ParseKinematics(in[j].content, in[j].name, {evals[0].t_max});
    if (!parsed.ok()) return parsed.status();
    // The work is checked before smoothing, which is itself linear in the frames.
    for (const EvaluationOptions& eval : evals) WORMDRAG_RETURN_IF_ERROR(CheckRecordingWork(*parsed, in[j].name, eval));
    auto r = SmoothRecording(in[j].name, *parsed, o, reports ? &(*reports)[j] : nullptr);
    if (!r.ok()) return r.status();
    k[j] = std::move(*r);
  }
  std::vector<std::shared_ptr<const PairedPath>> pairs;
  for (const EvaluationOptions& eval : evals) {
    auto pair = PairedPath::Create(k, {in[0].name, in[1].name}, eval);
    if (!pair.ok()) return pair.status();
    pairs.push_back(std::move(*pair));
  }
  return pairs;
}

}  // namespace

Result<int64_t> SubmitEstimateJob(JobStore& store, const std::array<JobInput, 2>& inputs, const JobOptions& options,
                                  bool reuse, bool* reused) {
  *reused = false;
  WORMDRAG_RETURN_IF_ERROR(options.estimate.Validate());
  // Build the pairs now so that bad input is refused before anything is stored.
  auto pairs = BuildPairs(inputs, options, {options.estimate.eval, options.estimate.ScreeningEval()});
  if (!pairs.ok()) return pairs.status();
  JobRecord job;
  job.kind = "estimate";
  const std::array<DatasetRecord, 2> ds = DatasetRecords(inputs, &job);
  job.options_json = options.ToJson();
  job.eval_key = EvalKey(job.dataset_hashes, options);
  if (reuse) {
    auto done = store.FindDoneJob(job.eval_key, job.options_json);
    if (!done.ok()) return done.status();
    if (done->has_value()) {
      *reused = true;
      return **done;
    }
  }
  return store.CreateJob(job, ds);
}

Result<std::vector<std::shared_ptr<const PairedPath>>> LoadPairs(JobStore& store, const JobRecord& job,
                                                                 const JobOptions& options,
                                                                 const std::vector<EvaluationOptions>& evals,
                                                                 std::array<SmoothingReport, 2>* reports) {
  auto in = LoadInputs(store, job);
  if (!in.ok()) return in.status();
  return BuildPairs(*in, options, evals, reports);
}

Result<std::shared_ptr<const PairedPath>> LoadPair(JobStore& store, const JobRecord& job, const JobOptions& options,
                                                   const EvaluationOptions& eval,
                                                   std::array<SmoothingReport, 2>* reports) {
  auto pairs = LoadPairs(store, job, options, {eval}, reports);
  if (!pairs.ok()) return pairs.status();
  return (*pairs)[0];
}

Status StoredEvaluator::Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                 const EvaluationRequest& request) {
  const bool mean_distance = request.objective == Objective::kMeanDistance;
  const bool stored_phase = request.phase >= 1 && request.phase <= 3;
  std::vector<std::optional<double>> known(sets.size());
  if (mean_distance && request.reuse && (request.phase == 1 || request.phase == 2))
    WORMDRAG_RETURN_IF_ERROR(store_.LookupEvaluations(eval_key_, sets, &known));
  std::vector<Coefficients> todo;
  std::vector<size_t> where;
  for (size_t i = 0; i < sets.size(); ++i)
    if (!known[i]) {
      todo.push_back(sets[i]);
      where.push_back(i);
    }
  reused_ += static_cast<int64_t>(sets.size() - todo.size());
  // A reused E is as exact as a fresh one: it tightens the phase's cut (the inner
  // evaluator offers the fresh ones).
  if (request.cut && mean_distance)
    for (const auto& k : known)
      if (k) request.cut->Offer(*k);
  EvaluationRequest inner = request;
  if (!request.set_cuts.empty()) {
    WORMDRAG_RETURN_IF_ERROR(CheckSetCuts(sets, request));
    inner.set_cuts.clear();
    for (size_t i = 0; i < sets.size(); ++i) {
      if (!known[i])
        inner.set_cuts.push_back(request.set_cuts[i]);
      else
        request.set_cuts[i]->Offer(*known[i]);
    }
  }
  std::vector<double> fresh;
  if (!todo.empty()) {
    const int64_t offset = static_cast<int64_t>(sets.size() - todo.size());
    if (request.progress)
      inner.progress = [&](int64_t done, int64_t) {
        request.progress(offset + done, static_cast<int64_t>(sets.size()));
      };
    WORMDRAG_RETURN_IF_ERROR(inner_.Evaluate(todo, &fresh, inner));
  }
  e->resize(sets.size());
  for (size_t i = 0; i < sets.size(); ++i)
    if (known[i]) (*e)[i] = *known[i];
  for (size_t k = 0; k < todo.size(); ++k) (*e)[where[k]] = fresh[k];
  if (mean_distance && stored_phase) {
    // Every set of the phase with an E is recorded for this job, reused ones included.
    // An abandoned set has none (only a bound): it is not stored, so neither a resumed
    // job nor `wormdrag results` nor the report can take it for an E; the phase summary
    // counts it.
    std::vector<EvaluationRecord> batch;
    batch.reserve(sets.size());
    for (size_t i = 0; i < sets.size(); ++i)
      if (!IsAbandoned((*e)[i])) batch.push_back({request.phase, sets[i], (*e)[i]});
    WORMDRAG_RETURN_IF_ERROR(store_.PutEvaluations(job_, batch));
  }
  return Status::Ok();
}

EvaluatorFactory LocalEvaluatorFactory(int threads) {
  return [threads](const JobRecord&, std::shared_ptr<const PairedPath> pair, const EvaluationOptions&,
                   bool) -> Result<std::unique_ptr<BatchEvaluator>> {
    return std::unique_ptr<BatchEvaluator>(new LocalEvaluator(std::move(pair), threads));
  };
}

Status RunEstimateJob(JobStore& store, int64_t job_id, const EvaluatorFactory& factory, const JobHooks& hooks,
                      const ReplicateRunner& replicates) {
  auto job = store.GetJob(job_id);
  if (!job.ok()) return job.status();
  if (job->state == JobState::kDone) return Status::Ok();
  if (job->state == JobState::kCancelled) return Status::Cancelled("job " + std::to_string(job_id) + " was cancelled");
  JobRun run(store, job_id, hooks);
  auto options = JobOptionsFromJson(job->options_json);
  if (!options.ok()) return run.Fail(options.status());
  WORMDRAG_RETURN_IF_ERROR(store.SetState(job_id, JobState::kRunning));
  const EstimateOptions& eo = options->estimate;
  std::array<SmoothingReport, 2> smoothing;
  auto pairs = LoadPairs(store, *job, *options, {eo.eval, eo.ScreeningEval()}, &smoothing);
  if (!pairs.ok()) return run.Fail(pairs.status());
  const std::shared_ptr<const PairedPath>& accurate_pair = (*pairs)[0];
  auto fast = factory(*job, (*pairs)[1], eo.ScreeningEval(), true);
  if (!fast.ok()) return run.Fail(fast.status());
  auto accurate = factory(*job, accurate_pair, eo.eval, false);
  if (!accurate.ok()) return run.Fail(accurate.status());
  StoredEvaluator stored_fast(store, job_id, job->eval_key, **fast);
  StoredEvaluator stored_accurate(store, job_id, job->eval_key, **accurate);

  EstimateHooks eh;
  eh.progress = [&](const std::string& phase, int64_t done, int64_t total, double best) {
    run.Progress(phase, done, total, best);
  };
  eh.survivors = [&](int phase, const std::vector<ScoredSet>& ranked) {
    std::vector<EvaluationRecord> recs;
    for (const auto& s : ranked) recs.push_back({phase, s.set, s.e});
    return store.PutSurvivors(job_id, phase, recs);
  };
  eh.cancelled = [&]() { return run.Cancelled(); };
  auto result = RunEstimate(stored_fast, stored_accurate, eo, accurate_pair->mean_body_length(), eh,
                            FactsOf(*accurate_pair));
  if (!result.ok()) return run.Fail(result.status());
  Json json = result->ToJson();
  json["smoothing"] = Json::array({smoothing[0].ToJson(), smoothing[1].ToJson()});
  if (options->bootstrap.replicates > 0 && result->explains_motion) {
    const ReplicateRunner runner = replicates ? replicates : LocalReplicateRunner(DefaultThreads());
    const int total = options->bootstrap.replicates;
    run.Progress("bootstrap", 0, total, result->best.e);
    // The smoothing check's data: the job's recordings with other shape smoothing.
    const DataAtSmoothing data_at_smoothing = [&](double scale) {
      JobOptions o = *options;
      o.spline.lambda_scale = scale;
      return LoadPair(store, *job, o, o.estimate.eval, nullptr);
    };
    auto bootstrap = RunBootstrap(
        *accurate_pair, result->best, {smoothing[0].noise_mm, smoothing[1].noise_mm}, *options, runner,
        options->smoothing == SmoothingMethod::kAuto ? data_at_smoothing : DataAtSmoothing(),
        [&](int done, int n) { run.Progress("bootstrap", done, n, result->best.e); }, [&] { return run.Cancelled(); });
    if (!bootstrap.ok()) return run.Fail(bootstrap.status());
    json["bootstrap"] = bootstrap->ToJson();
  }
  json["reused_evaluations"] = stored_fast.reused();
  return store.SetResult(job_id, Dump(json));
}

}  // namespace wormdrag
