// One consistent-enough look at the coordinator for the status page and /metrics:
// jobs (live progress for running ones, as `wormdrag watch` shows it; stored records for
// ended ones, as `wormdrag jobs show`), workers, task counters, quarantined tasks and
// the task store's commit latency. Read-only.
#pragma once

#include <chrono>
#include <map>
#include <vector>

#include "core/common/status.h"
#include "server/coordinator.h"

namespace wormdrag::server {

struct StatusSnapshot {
  std::chrono::system_clock::time_point now, started_at;
  std::vector<JobProgressView> active;  // running, then queued; oldest first
  std::vector<JobRecord> past;          // ended (done, failed, cancelled); newest first
  std::map<JobState, int64_t> jobs_by_state;
  int active_workers = 0;           // heard from within the lease period (the `workers` of `watch`)
  std::vector<WorkerView> workers;  // heard from within worker_forget_seconds
  double worker_forget_seconds = 0;
  TaskCounters tasks;
  std::vector<QuarantinedTask> quarantined;                // oldest first
  std::map<std::string, std::string> quarantined_workers;  // worker -> why (spot-checks)
  CommitStats commits;
  double sets_per_second = 0;
  int64_t sets_total = 0;
  double lease_seconds = 0;
};

// `past_jobs`: how many ended jobs to list (newest first).
Result<StatusSnapshot> CollectStatus(Coordinator& c, int past_jobs);

}  // namespace wormdrag::server
