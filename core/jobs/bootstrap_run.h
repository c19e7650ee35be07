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

// The refit of replicate `index`: deterministic in (pair, estimate, noise, options,
// index), so a worker or a restarted run gets the same answer. `summary`, if given,
// receives the refit's Phase 3 summary.
Result<ScoredSet> FitReplicate(const PairedPath& pair, const ScoredSet& estimate, const std::array<double, 2>& noise_mm,
                               const JobOptions& options, int index, PhaseSummary* summary = nullptr);

struct BootstrapHooks {
  std::function<void(int done, int total)> progress;
  std::function<bool()> cancelled;
};

// A refit as a worker task: its payload and the values a worker reports
// (1 = refitted or 0 = failed, then μ_n, μ_t, η_n, η_t).
struct ReplicateTask {
  int index = 0;
  ScoredSet estimate;
  std::array<double, 2> noise_mm{};  // what the replicate carries (floor applied)
};
std::string ReplicateTaskToJson(const ReplicateTask& t);
Result<ReplicateTask> ReplicateTaskFromJson(const std::string& json);
std::vector<double> RunReplicateTask(const PairedPath& pair, const ReplicateTask& t, const JobOptions& options);

// The replicates' noise per worm: the recording's, at least the options' floor; and the
// share of the data's noise variance in it (SummariseBootstrap's bias_share).
std::array<double, 2> ReplicateNoise(const PairedPath& pair, const std::array<double, 2>& noise_mm,
                                     const BootstrapOptions& o, double* bias_share);

Result<BootstrapReport> RunBootstrapLocal(const PairedPath& pair, const ScoredSet& estimate,
                                          const std::array<double, 2>& noise_mm, const JobOptions& options,
                                          int threads, const BootstrapHooks& hooks = {});

}  // namespace wormdrag
