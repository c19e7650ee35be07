// Estimation jobs on the job store: what `wormdrag estimate` runs in one process and
// what the coordinator runs with workers. The science stays in core/estimate; this
// layer records it (every evaluated set, the survivors, the result) and resumes it.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/estimate/bootstrap.h"
#include "core/estimate/estimator.h"
#include "core/filter/butterworth.h"
#include "core/filter/shape_smoothing.h"
#include "core/jobs/job_run.h"
#include "core/store/job_store.h"

namespace wormdrag {

// Everything a job needs besides its recordings.
struct JobOptions {
  EstimateOptions estimate;
  // How the recorded shapes are smoothed before they drive the model. Default: auto
  // (a smoothing spline chosen by GCV per recording), which leaves clean data unchanged
  // and removes tracking noise; the paper's 5 Hz Butterworth (lowpass) attenuates a
  // swimming gait's harmonics and biases the fit even on clean data.
  SmoothingMethod smoothing = SmoothingMethod::kAuto;
  SmoothingSplineOptions spline;  // for auto
  double lowpass_hz = 5.0;        // for lowpass: Butterworth cut-off of the joint angles
  bool causal_filter = false;     // for lowpass: forward only
  BootstrapOptions bootstrap;     // intervals; replicates = 0 turns them off
  std::string ToJson() const;     // canonical, stored with the job
};
// What a job's stored options are read for. Analysing a finished job never reruns its
// bootstrap, so its refit count is not held to today's minimum (MinReplicates), which
// is higher than the one some jobs were stored under.
enum class OptionsUse { kRun, kAnalyse };
Result<JobOptions> JobOptionsFromJson(const std::string& json, OptionsUse use = OptionsUse::kRun);

// The evaluation key: recordings and every option that changes E. Jobs with the same
// key reuse each other's stored Phase 1/2 evaluations.
std::string EvalKey(const std::array<std::string, 2>& dataset_hashes, const JobOptions& o);

// Validates the inputs (parses both recordings, builds the pair) and options, then
// creates the job (state queued). Nothing is stored when validation fails.
// With `reuse`, a finished job with the same inputs and options is returned instead
// (*reused = true).
Result<int64_t> SubmitEstimateJob(JobStore& store, const std::array<JobInput, 2>& inputs, const JobOptions& options,
                                  bool reuse, bool* reused);

// The paired paths of a stored job, one per evaluation (same t_max), from recordings
// smoothed once. `reports`, if given, receives each recording's smoothing report.
Result<std::vector<std::shared_ptr<const PairedPath>>> LoadPairs(JobStore& store, const JobRecord& job,
                                                                 const JobOptions& options,
                                                                 const std::vector<EvaluationOptions>& evals,
                                                                 std::array<SmoothingReport, 2>* reports = nullptr);
// LoadPairs for one evaluation.
Result<std::shared_ptr<const PairedPath>> LoadPair(JobStore& store, const JobRecord& job, const JobOptions& options,
                                                   const EvaluationOptions& eval,
                                                   std::array<SmoothingReport, 2>* reports = nullptr);
// Parses, smooths (as the options say) and checks one recording; `report`, if given,
// receives what the smoothing did and the tracking noise it estimated.
Result<Kinematics> PrepareRecording(const std::string& name, const std::string& content, const JobOptions& options,
                                    SmoothingReport* report = nullptr);
// The smoothing step alone, for recordings already parsed (bootstrap replicates).
Result<Kinematics> SmoothRecording(const std::string& name, const Kinematics& k, const JobOptions& options,
                                   SmoothingReport* report = nullptr);

// Decorates an evaluator: Phase 1/2 values already stored under the job's eval key
// are reused (that is how a restarted or repeated job skips finished work), and
// every new E of phases 1–3 is stored, one transaction per call.
class StoredEvaluator : public BatchEvaluator {
 public:
  StoredEvaluator(JobStore& store, int64_t job, std::string eval_key, BatchEvaluator& inner)
      : store_(store), job_(job), eval_key_(std::move(eval_key)), inner_(inner) {}
  Status Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                  const EvaluationRequest& request = {}) override;
  Status EvaluateResiduals(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                           const EvaluationRequest& request = {}) override {
    return inner_.EvaluateResiduals(sets, residuals, request);
  }
  bool HasJacobians() const override { return inner_.HasJacobians(); }
  Status EvaluateResidualJacobians(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                                   std::vector<std::vector<double>>* jacobians,
                                   const EvaluationRequest& request = {}) override {
    return inner_.EvaluateResidualJacobians(sets, residuals, jacobians, request);
  }
  int parallelism() const override { return inner_.parallelism(); }
  int64_t reused() const { return reused_; }

 private:
  JobStore& store_;
  int64_t job_;
  std::string eval_key_;
  BatchEvaluator& inner_;
  int64_t reused_ = 0;
};

// Makes the evaluator for one accuracy level of a job (embedded: threads; the
// coordinator: tasks for workers).
using EvaluatorFactory = std::function<Result<std::unique_ptr<BatchEvaluator>>(
    const JobRecord& job, std::shared_ptr<const PairedPath> pair, const EvaluationOptions& eval, bool screening)>;

// One bootstrap refit: a replicate pair made from `model` (the estimate unless set)
// with the given noise, smoothed as the job smoothed its data, refitted by Phase 3
// from `estimate` (core/jobs/bootstrap_run.h). With `refit_data`, no replicate is
// made: the job's own recordings, their shape smoothing's λ scaled by
// `smoothing_scale`, are refitted (the smoothing check).
struct ReplicateTask {
  int index = 0;                      // seeds the replicate's noise
  ScoredSet estimate;                 // the job's estimate: where the refit starts
  std::optional<Coefficients> model;  // the set the replicate is made from
  std::array<double, 2> noise_mm{};   // what the replicate carries (floor applied)
  bool refit_data = false;
  double smoothing_scale = 1;
};

// Runs bootstrap refits, in order: each refit's set and its E against the pair it
// refitted (nullopt: the refit failed). Embedded: threads; the coordinator: worker
// tasks. Progress: refits done of the batch's total.
using ReplicateRunner = std::function<Result<std::vector<std::optional<ScoredSet>>>(
    const PairedPath& pair, const std::vector<ReplicateTask>& tasks, const JobOptions& options,
    const std::function<void(int done, int total)>& progress, const std::function<bool()>& cancelled)>;

// Runs a queued or interrupted job to the end: state running → done (result stored)
// or failed (error stored) or cancelled. Returns the final status of the run.
// The bootstrap's refits run through `replicates` (empty: in this process, on all cores).
Status RunEstimateJob(JobStore& store, int64_t job_id, const EvaluatorFactory& factory, const JobHooks& hooks = {},
                      const ReplicateRunner& replicates = {});

// The embedded factory: LocalEvaluator with `threads` threads.
EvaluatorFactory LocalEvaluatorFactory(int threads);

}  // namespace wormdrag
