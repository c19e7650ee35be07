// The bootstrap stage of an estimation job (core/estimate/bootstrap.h): makes each
// replicate pair, smooths it as the job smoothed its recordings, and refits it with
// Phase 3 from the estimate. Embedded, replicates run side by side on threads, each
// refit on one thread (a replicate is independent work; a Phase 3 from one start has
// little parallelism of its own).
#pragma once

#include <array>
#include <functional>
#include <memory>

#include "core/estimate/bootstrap.h"
#include "core/estimate/search.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag {

// The refit of one replicate: Phase 3 from the estimate, then bounded in scale as the
// job bounds the data's fit (BoundScaleOf); a refit with no finite E fails.
// Deterministic in (pair, task, options), so a worker or a restarted run gets the same
// answer. `summary`, if given, receives the refit's Phase 3 summary. It evaluates on
// `threads` threads (the answer does not depend on them): a worker gives a refit all
// of its cores, a job running many refits side by side gives each one.
Result<ScoredSet> FitReplicate(const PairedPath& pair, const ReplicateTask& task, const JobOptions& options,
                               PhaseSummary* summary = nullptr, int threads = 1);

// A refit as a worker task: the payload the coordinator keeps (and makes the task's id
// from; workers get it typed, proto/convert.h) and the values a worker reports
// (1 = refitted or 0 = failed, then μ_n, μ_t, η_n, η_t and the refit's E in mm).
std::string ReplicateTaskToJson(const ReplicateTask& t);
Result<ReplicateTask> ReplicateTaskFromJson(const std::string& json);
// InvalidArgument unless a refit a worker was sent is one it can run: values finite and
// >= 0, index and smoothing scale in range (ReplicateTaskFromJson checks it too).
Status CheckReplicateTask(const ReplicateTask& t);
std::vector<double> RunReplicateTask(const PairedPath& pair, const ReplicateTask& t, const JobOptions& options,
                                     int threads = 1);

// The replicates' noise per worm: the recording's, at least the options' floor; and the
// share of the data's noise variance in it (SummariseBootstrap's bias_share).
std::array<double, 2> ReplicateNoise(const PairedPath& pair, const std::array<double, 2>& noise_mm,
                                     const BootstrapOptions& o, double* bias_share);

// The bootstrap of a finished estimate: `replicates` refits of replicates made from
// the estimate give the basic intervals (SummariseBootstrap); then each combination
// they call determined is checked against replicates made with it moved to its
// corrected value × and ÷ `check_factor` (BootstrapOptions): if the data's own fit
// lies within the range of such refits, the data cannot tell those values apart and
// the combination is not determined (the basic interval assumes the estimator's bias
// is the same across it, which fails where E is steep on one side only).
//
// The goodness-of-fit test (CheckMisfit) compares `estimate.e`, the data's E, with the
// refits' before either check, and a misfit above every refit's spends no check refit.
//
// Before that check, the smoothing check (BootstrapOptions::smoothing_check) refits the
// data smoothed with other λ; `data_at_smoothing(scale)` builds the data pair with
// its shape smoothing's λ scaled (empty: no smoothing check).
//
// `progress(done, total)` counts the refits finished: first of the replicates, then,
// once the check's are known, of all of them (the total grows, `done` never falls).
using DataAtSmoothing = std::function<Result<std::shared_ptr<const PairedPath>>(double lambda_scale)>;
Result<BootstrapReport> RunBootstrap(const PairedPath& pair, const ScoredSet& estimate,
                                     const std::array<double, 2>& noise_mm, const JobOptions& options,
                                     const ReplicateRunner& runner, const DataAtSmoothing& data_at_smoothing,
                                     const std::function<void(int done, int total)>& progress = {},
                                     const std::function<bool()>& cancelled = {});

// The embedded runner: refits side by side on `threads` threads of this process.
ReplicateRunner LocalReplicateRunner(int threads);

}  // namespace wormdrag
