// Lost leases: the reaper that revokes expired leases and passed deadlines, the count
// of lost leases that quarantines a poison task, and their durable record.
#include <chrono>
#include <mutex>
#include <vector>

#include <spdlog/spdlog.h>

#include "server/scheduler.h"

namespace wormdrag::server {

void Scheduler::ReaperLoop() {
  std::unique_lock<std::mutex> l(mu_);
  while (!stopping_) {
    done_cv_.wait_for(l, std::chrono::milliseconds(200));
    if (stopping_) break;
    l.unlock();
    ReapExpired();
    l.lock();
  }
}

void Scheduler::ReapExpired() {
  std::vector<AttemptsWrite> writes;
  {
    std::lock_guard<std::mutex> l(mu_);
    const auto now = Now();
    for (auto it = leased_.begin(); it != leased_.end();) {
      auto t = tasks_.find(*it);
      if (t == tasks_.end() || t->second->state != State::kLeased) {
        it = leased_.erase(it);
        continue;
      }
      Task& task = *t->second;
      std::string why;
      if (task.deadline < now)
        why = "ran past its deadline of " + std::to_string(static_cast<int64_t>(DeadlineFor(task.spec, opt_))) + " s";
      else if (task.expiry < now)
        why = "expired";
      if (why.empty()) {
        ++it;
        continue;
      }
      it = leased_.erase(it);  // before LoseLease, which may quarantine (and erase) it
      LoseLease(task, why, &writes);
    }
    ReviewSpotChecks();
    ForgetSilentWorkers();
  }
  WriteAttempts(writes);
}

void Scheduler::LoseLease(Task& task, const std::string& why, std::vector<AttemptsWrite>* writes) {
  ++expired_total_;
  ++task.lost;
  task.lost_by += (task.lost_by.empty() ? "" : ",") + task.worker;
  task.error = "lease " + why + " on worker " + task.worker;
  task.lease_id.clear();
  if (task.lost >= opt_.max_lost_leases) {
    spdlog::warn("lease of task {} (job {}) by worker {} {} (lost {} of {})", task.spec.id, task.spec.job, task.worker,
                 why, task.lost, opt_.max_lost_leases);
    Quarantine(task, task.lost_by, task.error);
  } else {
    spdlog::warn("lease of task {} (job {}) by worker {} {}; back to the queue (lost {} of {})", task.spec.id,
                 task.spec.job, task.worker, why, task.lost, opt_.max_lost_leases);
    task.state = State::kQueued;
    auto j = jobs_.find(task.spec.job);
    if (j != jobs_.end()) j->second.queue.push_front(task.spec.id);
    work_cv_.notify_all();
  }
  writes->push_back(AttemptsOf(task));
}

void Scheduler::Quarantine(Task& t, const std::string& worker, const std::string& reason) {
  t.state = State::kQuarantined;
  t.lease_id.clear();
  leased_.erase(t.spec.id);
  const bool lost = t.lost >= opt_.max_lost_leases;
  spdlog::error("event=task_quarantined task={} job={} failures={} lost_leases={} workers={} reason=\"{}\"", t.spec.id,
                t.spec.job, t.attempts, t.lost, lost ? t.lost_by : worker, reason);
  ++quarantined_total_;
  quarantined_.push_back({t.spec.id, lost ? t.lost_by : worker, reason, t.spec.job, t.attempts + t.lost,
                          std::chrono::system_clock::now()});
  if (quarantined_.size() > kQuarantineKept) quarantined_.pop_front();
  done_cv_.notify_all();
}

Scheduler::AttemptsWrite Scheduler::AttemptsOf(const Task& t) {
  return {t.spec.id, t.spec.job, TaskAttempts{t.attempts, t.lost, t.lost_by, t.error}};
}

void Scheduler::WriteAttempts(const std::vector<AttemptsWrite>& writes) {
  for (const auto& w : writes)
    if (Status st = store_->PutAttempts(w.id, w.job, w.attempts); !st.ok())
      spdlog::error("event=task_attempts_not_stored task={} job={} error=\"{}\"", w.id, w.job, st.message());
}

}  // namespace wormdrag::server
