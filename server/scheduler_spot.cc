// The Scheduler's spot-checks and worker registry (scheduler.h, spot_check.h).
#include <algorithm>

#include <spdlog/spdlog.h>

#include "server/scheduler.h"
#include "server/spot_check.h"

namespace wormdrag::server {

namespace {

std::string Names(const std::vector<std::pair<std::string, TaskResult>>& candidates) {
  std::string s;
  for (const auto& [w, r] : candidates) s += (s.empty() ? "" : ",") + w;
  return s;
}

}  // namespace

bool Scheduler::Live(const std::string& worker, Clock::time_point now) const {
  if (quarantined_workers_.count(worker)) return false;
  if (auto p = polling_.find(worker); p != polling_.end() && p->second > 0) return true;
  auto w = workers_.find(worker);
  return w != workers_.end() &&
         w->second >= now - std::chrono::milliseconds(static_cast<int64_t>(opt_.lease_seconds * 1000));
}

bool Scheduler::Excluded(const Task& t, const std::string& worker) const {
  for (const auto& c : t.candidates)
    if (c.first == worker) return true;
  return false;
}

bool Scheduler::OtherLiveWorker(const Task& t) {
  // Stricter than Live: a worker that will ask for work soon is polling now, holds a
  // lease (it polls when done), or called within the last few seconds (between a
  // report and its next poll). A client that leased by hand once, or a worker that
  // just died, does not hold a result back for a whole lease period.
  const auto now = Now();
  const auto recent = now - std::chrono::milliseconds(
                                static_cast<int64_t>(std::min(opt_.lease_seconds, kSpotCheckRecentSeconds) * 1000));
  std::set<std::string> holders;
  for (const auto& id : leased_)
    if (auto it = tasks_.find(id); it != tasks_.end() && it->second->state == State::kLeased)
      holders.insert(it->second->worker);
  for (const auto& [w, seen] : workers_) {
    if (Excluded(t, w) || quarantined_workers_.count(w)) continue;
    const auto p = polling_.find(w);
    if ((p != polling_.end() && p->second > 0) || holders.count(w) || seen >= recent) return true;
  }
  return false;
}

void Scheduler::Requeue(Task& t) {
  t.state = State::kQueued;
  t.lease_id.clear();
  leased_.erase(t.spec.id);
  auto j = jobs_.find(t.spec.job);
  if (j != jobs_.end()) j->second.queue.push_front(t.spec.id);
  work_cv_.notify_all();
}

bool Scheduler::SpotCheck(Task& t, const std::string& worker, TaskResult* result) {
  const std::string& id = t.spec.id;
  t.candidates.emplace_back(worker, std::move(*result));
  auto& c = t.candidates;
  if (c.size() == 1) {
    if (!OtherLiveWorker(t)) {
      // One worker: nobody to compare with, and waiting would stall its job.
      spdlog::info("event=spot_check_skipped task={} job={} worker={} reason=\"no other live worker\"", id, t.spec.job,
                   worker);
      *result = std::move(c[0].second);
      c.clear();
      return true;
    }
    ++spot_checks_total_;
    spdlog::info("event=spot_check task={} job={} first={}", id, t.spec.job, worker);
    Requeue(t);
    spot_pending_.insert(id);
    return false;
  }
  const double tol = opt_.spot_check_tolerance;
  if (c.size() == 2) {
    if (ResultsAgree(c[0].second, c[1].second, tol, t.spec)) {
      spdlog::info("event=spot_check_passed task={} job={} workers={}", id, t.spec.job, Names(c));
      *result = std::move(c[0].second);
      c.clear();
      spot_pending_.erase(id);
      return true;
    }
    ++spot_mismatches_total_;
    spdlog::warn("event=spot_check_mismatch task={} job={} workers={} reason=\"a third worker decides\"", id,
                 t.spec.job, Names(c));
    Requeue(t);
    spot_pending_.insert(id);
    return false;
  }
  // Three opinions: the odd one out is quarantined, the agreeing pair's result stands.
  spot_pending_.erase(id);
  for (size_t keep : {size_t{0}, size_t{1}}) {
    if (!ResultsAgree(c[2].second, c[keep].second, tol, t.spec)) continue;
    const std::string loser = c[1 - keep].first;
    const std::string why = "its result for task " + id + " differs from those of workers " + c[keep].first + " and " +
                            c[2].first;
    *result = std::move(c[keep].second);
    c.clear();
    QuarantineWorker(loser, why);
    return true;
  }
  const std::string names = Names(c);
  c.clear();
  t.error = "workers " + names + " returned three different results (spot-check)";
  Quarantine(t, names, t.error);
  return false;
}

void Scheduler::QuarantineWorker(const std::string& worker, const std::string& reason) {
  if (!quarantined_workers_.emplace(worker, reason).second) return;
  spdlog::error("event=worker_quarantined worker={} reason=\"{}\"", worker, reason);
  // Its leases go back to the queue (not lost: it did not die), and its results
  // still waiting for a second opinion are dropped.
  for (auto& [id, t] : tasks_) {
    if (t->state == State::kLeased && t->worker == worker) Requeue(*t);
    auto& c = t->candidates;
    for (auto it = c.begin(); it != c.end();) it = it->first == worker ? c.erase(it) : it + 1;
    if (c.empty()) spot_pending_.erase(id);
  }
}

bool Scheduler::WorkerQuarantined(const std::string& worker, std::string* reason) {
  std::lock_guard<std::mutex> l(mu_);
  auto it = quarantined_workers_.find(worker);
  if (it == quarantined_workers_.end()) return false;
  if (reason) *reason = it->second;
  return true;
}

std::map<std::string, std::string> Scheduler::QuarantinedWorkers() {
  std::lock_guard<std::mutex> l(mu_);
  return quarantined_workers_;
}

void Scheduler::ReviewSpotChecks() {
  for (auto it = spot_pending_.begin(); it != spot_pending_.end();) {
    auto t = tasks_.find(*it);
    if (t == tasks_.end() || t->second->state == State::kDone || t->second->state == State::kQuarantined ||
        t->second->candidates.empty()) {
      it = spot_pending_.erase(it);
      continue;
    }
    Task& task = *t->second;
    if (task.state != State::kQueued || OtherLiveWorker(task)) {
      ++it;
      continue;
    }
    if (task.candidates.size() == 1) {
      // The other workers left: the task runs again unchecked, wherever it can.
      spdlog::info("event=spot_check_skipped task={} job={} worker={} reason=\"no other live worker\"", task.spec.id,
                   task.spec.job, task.candidates[0].first);
      task.candidates.clear();
      task.spot = false;
      work_cv_.notify_all();
      it = spot_pending_.erase(it);
      continue;
    }
    // Two that disagree and nobody to decide: neither result can be trusted, so the
    // task waits for a third worker.
    ++it;
  }
}

void Scheduler::ForgetSilentWorkers() {
  const auto cutoff = Now() - opt_.WorkerForgetAfter();
  for (auto it = workers_.begin(); it != workers_.end();) {
    const auto p = polling_.find(it->first);
    if (it->second < cutoff && (p == polling_.end() || p->second == 0)) {
      spdlog::info("event=worker_forgotten worker={} reason=\"silent for {} lease periods\"", it->first,
                   opt_.worker_forget_leases);
      polling_.erase(it->first);
      it = workers_.erase(it);
    } else {
      ++it;
    }
  }
}

std::vector<std::string> Scheduler::Workers() {
  std::lock_guard<std::mutex> l(mu_);
  std::vector<std::string> out;
  for (const auto& [w, seen] : workers_) out.push_back(w);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace wormdrag::server
