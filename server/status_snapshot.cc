#include "server/status_snapshot.h"

namespace wormdrag::server {

namespace {
bool Ended(JobState s) {
  return s == JobState::kDone || s == JobState::kFailed || s == JobState::kCancelled;
}
}  // namespace

Result<StatusSnapshot> CollectStatus(Coordinator& c, int past_jobs) {
  StatusSnapshot s;
  s.now = std::chrono::system_clock::now();
  s.started_at = c.started_at();
  auto counts = c.store().CountJobsByState();
  if (!counts.ok()) return counts.status();
  s.jobs_by_state = std::move(*counts);
  for (JobState state : {JobState::kRunning, JobState::kQueued}) {
    auto jobs = c.store().JobsInState(state);
    if (!jobs.ok()) return jobs.status();
    for (const auto& j : *jobs) {
      auto p = c.Progress(j.id);
      if (p.ok()) s.active.push_back(std::move(*p));
    }
  }
  // The newest jobs include the active ones; ask for enough to fill the list after them.
  auto recent = c.store().ListJobs(past_jobs + static_cast<int>(s.active.size()));
  if (!recent.ok()) return recent.status();
  for (auto& j : *recent)
    if (Ended(j.state) && static_cast<int>(s.past.size()) < past_jobs) s.past.push_back(std::move(j));
  s.active_workers = c.scheduler().ActiveWorkers();
  s.workers = c.activity().Workers();
  s.worker_forget_seconds = std::chrono::duration<double>(c.activity().forget_after()).count();
  s.tasks = c.scheduler().Counters();
  s.quarantined = c.scheduler().Quarantined();
  s.quarantined_workers = c.scheduler().QuarantinedWorkers();
  s.commits = c.task_store().commit_stats();
  s.sets_per_second = c.activity().SetsPerSecond();
  s.sets_total = c.activity().sets_total();
  s.lease_seconds = c.scheduler().lease_seconds();
  return s;
}

}  // namespace wormdrag::server
