// The job's side of the scheduler: a job registers, runs its batches of tasks (each
// answered from the store when its result is already durable) and is cancelled.
#include <memory>
#include <optional>
#include <vector>

#include <spdlog/spdlog.h>

#include "server/scheduler.h"
#include "server/spot_check.h"

namespace wormdrag::server {

void Scheduler::AddJob(int64_t job, const JobInfo& info) {
  std::lock_guard<std::mutex> l(mu_);
  auto& q = jobs_[job];
  q.info = info;
}

void Scheduler::RemoveJob(int64_t job) {
  std::lock_guard<std::mutex> l(mu_);
  jobs_.erase(job);
}

void Scheduler::CancelJob(int64_t job) {
  std::lock_guard<std::mutex> l(mu_);
  auto it = jobs_.find(job);
  if (it == jobs_.end()) return;
  it->second.cancelled = true;
  it->second.queue.clear();
  done_cv_.notify_all();
}

bool Scheduler::IsCancelled(int64_t job) {
  std::lock_guard<std::mutex> l(mu_);
  auto it = jobs_.find(job);
  return it != jobs_.end() && it->second.cancelled;
}

Status Scheduler::LoadStored(const std::vector<TaskSpec>& tasks, std::vector<std::optional<TaskResult>>* stored,
                             std::vector<std::optional<TaskAttempts>>* attempts) {
  stored->assign(tasks.size(), std::nullopt);
  attempts->assign(tasks.size(), std::nullopt);
  for (size_t i = 0; i < tasks.size(); ++i) {
    if (IsDurable(tasks[i].kind)) {
      auto g = store_->Get(tasks[i].id);
      if (!g.ok()) return g.status();
      if (g->has_value()) {
        TaskResult r;
        if (DecodeResult(**g, &r)) (*stored)[i] = std::move(r);
      }
    }
    if ((*stored)[i]) continue;
    auto a = store_->GetAttempts(tasks[i].id);
    if (!a.ok()) return a.status();
    (*attempts)[i] = std::move(*a);
  }
  return Status::Ok();
}

std::vector<std::shared_ptr<Scheduler::Task>> Scheduler::Hold(std::vector<TaskSpec> tasks,
                                                              std::vector<std::optional<TaskResult>> stored,
                                                              const std::vector<std::optional<TaskAttempts>>& attempts,
                                                              std::deque<std::string>* queue) {
  std::vector<std::shared_ptr<Task>> mine;
  for (size_t i = 0; i < tasks.size(); ++i) {
    auto& slot = tasks_[tasks[i].id];
    if (!slot) {
      slot = std::make_shared<Task>();
      slot->spec = std::move(tasks[i]);
      slot->spot = IsSpotCheckable(slot->spec.kind) && IsSpotChecked(slot->spec.id, opt_.spot_check_fraction);
      if (stored[i]) {
        slot->state = State::kDone;
        slot->result = std::move(*stored[i]);
      } else {
        if (attempts[i]) {
          slot->attempts = attempts[i]->failures;
          slot->lost = attempts[i]->lost;
          slot->lost_by = attempts[i]->workers;
          slot->error = attempts[i]->last_error;
          spdlog::info("event=task_attempts_restored task={} job={} failures={} lost_leases={}", slot->spec.id,
                       slot->spec.job, slot->attempts, slot->lost);
        }
        if (slot->lost >= opt_.max_lost_leases || slot->attempts >= opt_.max_attempts)
          Quarantine(*slot, slot->worker, slot->error);
        else
          queue->push_back(slot->spec.id);
      }
    }
    ++slot->waiters;
    mine.push_back(slot);
  }
  return mine;
}

void Scheduler::Release(const std::vector<std::shared_ptr<Task>>& mine) {
  for (const auto& t : mine) {
    if (--t->waiters == 0) {
      // Consumed (or abandoned): queued copies are skipped lazily by Lease, a late
      // report finds the durable result or gets NOT_FOUND.
      leased_.erase(t->spec.id);
      tasks_.erase(t->spec.id);
    }
  }
}

Status Scheduler::QuarantineStatus(const Task& t) const {
  if (t.lost >= opt_.max_lost_leases)
    return Status::Internal("task " + t.spec.id + " was quarantined: it lost its lease " + std::to_string(t.lost) +
                            " times (workers " + t.lost_by +
                            " died, stalled or ran past its deadline on it); last: " + t.error);
  if (t.attempts >= opt_.max_attempts)
    return Status::Internal("task " + t.spec.id + " failed " + std::to_string(t.attempts) +
                            " times and was quarantined; last error: " + t.error);
  // A spot-check found no two workers that agree.
  return Status::Internal("task " + t.spec.id + " was quarantined: " + t.error);
}

Status Scheduler::Run(int64_t job, std::vector<TaskSpec> tasks, std::vector<TaskResult>* results,
                      const std::function<void(int64_t)>& progress) {
  // Results made durable before a restart answer their tasks directly; attempts
  // counted before a restart still count.
  std::vector<std::optional<TaskResult>> stored;
  std::vector<std::optional<TaskAttempts>> attempts;
  WORMDRAG_RETURN_IF_ERROR(LoadStored(tasks, &stored, &attempts));
  std::unique_lock<std::mutex> l(mu_);
  if (stopping_) return Status::Unavailable("coordinator is shutting down");
  auto jq = jobs_.find(job);
  if (jq == jobs_.end()) return Status::Internal("job " + std::to_string(job) + " is not registered for tasks");
  if (jq->second.cancelled) return Status::Cancelled("job " + std::to_string(job) + " was cancelled");
  const std::vector<std::shared_ptr<Task>> mine = Hold(std::move(tasks), std::move(stored), attempts,
                                                       &jq->second.queue);
  work_cv_.notify_all();

  Status st;
  int64_t reported = -1;
  for (;;) {
    int64_t done_sets = 0;
    bool all = true;
    for (const auto& t : mine) {
      if (t->state == State::kDone) {
        done_sets += t->spec.units();
        continue;
      }
      all = false;
      if (t->state == State::kQuarantined) {
        st = QuarantineStatus(*t);
        break;
      }
    }
    if (!st.ok()) break;
    auto j = jobs_.find(job);
    if (j == jobs_.end() || j->second.cancelled) {
      st = Status::Cancelled("job " + std::to_string(job) + " was cancelled");
      break;
    }
    if (stopping_) {
      st = Status::Unavailable("coordinator is shutting down");
      break;
    }
    if (all) break;
    if (done_sets != reported && progress) {
      reported = done_sets;
      l.unlock();
      progress(done_sets);
      l.lock();
      continue;
    }
    done_cv_.wait_for(l, std::chrono::milliseconds(250));
  }
  if (st.ok()) {
    results->clear();
    results->reserve(mine.size());
    for (const auto& t : mine) results->push_back(t->result);
  }
  Release(mine);
  return st;
}

}  // namespace wormdrag::server
