#include "server/scheduler.h"

#include <cstring>
#include <random>

#include <spdlog/spdlog.h>

#include "core/store/job_store.h"
#include "server/spot_check.h"

namespace wormdrag::server {

namespace {
using SteadyClock = std::chrono::steady_clock;

class RealClock final : public Clock {
 public:
  time_point Now() const override { return SteadyClock::now(); }
};

std::chrono::milliseconds Millis(double seconds) {
  return std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
}

}  // namespace

const Clock& Clock::Real() {
  static const RealClock clock;
  return clock;
}

double DeadlineFor(const TaskSpec& spec, const SchedulerOptions& o) {
  return o.deadline_seconds + o.deadline_seconds_per_set * static_cast<double>(spec.sets.size());
}

Scheduler::Scheduler(TaskStore* store, SchedulerOptions options)
    : store_(store), opt_(options), clock_(options.clock ? options.clock : &Clock::Real()) {
  lease_salt_ = std::random_device{}();
  lease_salt_ = (lease_salt_ << 32) ^ std::random_device{}();
  if (opt_.reaper_thread) reaper_ = std::thread([this] { ReaperLoop(); });
}

Scheduler::~Scheduler() {
  Stop();
  if (reaper_.joinable()) reaper_.join();
}

void Scheduler::Stop() {
  std::lock_guard<std::mutex> l(mu_);
  stopping_ = true;
  work_cv_.notify_all();
  done_cv_.notify_all();
}

bool Scheduler::Lease(const std::string& worker, std::chrono::milliseconds wait, LeasedTask* out) {
  std::unique_lock<std::mutex> l(mu_);
  if (quarantined_workers_.count(worker)) return false;
  // The long poll is real time whatever the clock: it is how long an RPC is held.
  const auto deadline = SteadyClock::now() + wait;
  // A worker waiting here is live (spot-checks may count on it).
  ++polling_[worker];
  struct Unpoll {
    std::unordered_map<std::string, int>& polling;
    const std::string& worker;
    ~Unpoll() {
      if (auto p = polling.find(worker); p != polling.end()) --p->second;
    }
  } unpoll{polling_, worker};
  for (;;) {
    workers_[worker] = Now();
    if (stopping_ || quarantined_workers_.count(worker)) return false;
    // Round-robin over jobs with queued work, starting after the last job served.
    for (int pass = 0; pass < 2; ++pass) {
      auto it = pass == 0 ? jobs_.upper_bound(rr_cursor_) : jobs_.begin();
      for (; it != jobs_.end(); ++it) {
        if (pass == 1 && it->first > rr_cursor_) break;
        auto& q = it->second.queue;
        // The first task this worker may take; stale entries are dropped on the way,
        // tasks awaiting another worker's opinion are left for others.
        for (size_t k = 0; k < q.size();) {
          const std::string id = q[k];
          auto t = tasks_.find(id);
          if (t == tasks_.end() || t->second->state != State::kQueued) {
            q.erase(q.begin() + static_cast<std::ptrdiff_t>(k));
            continue;
          }
          if (Excluded(*t->second, worker)) {
            ++k;
            continue;
          }
          q.erase(q.begin() + static_cast<std::ptrdiff_t>(k));
          Task& task = *t->second;
          const auto now = Now();
          task.state = State::kLeased;
          task.worker = worker;
          task.lease_id = "l" + std::to_string(lease_salt_) + "-" + std::to_string(++lease_seq_);
          task.expiry = now + Millis(opt_.lease_seconds);
          task.deadline = now + Millis(DeadlineFor(task.spec, opt_));
          leased_.insert(id);
          ++leases_total_;
          rr_cursor_ = it->first;
          out->spec = task.spec;
          out->job = it->second.info;
          out->lease_id = task.lease_id;
          return true;
        }
      }
    }
    if (work_cv_.wait_until(l, deadline) == std::cv_status::timeout) {
      if (SteadyClock::now() >= deadline) {
        // One more look happens only if woken; a timed-out poll answers "nothing".
        return false;
      }
    }
  }
}

void Scheduler::Heartbeat(const std::string& worker, const std::vector<std::string>& ids,
                          std::vector<std::string>* cancelled) {
  std::lock_guard<std::mutex> l(mu_);
  const auto now = Now();
  workers_[worker] = now;
  for (const auto& id : ids) {
    auto t = tasks_.find(id);
    if (t == tasks_.end() || t->second->state == State::kDone || t->second->state == State::kQuarantined) {
      cancelled->push_back(id);
      continue;
    }
    // A lease this worker lost (expired, past the deadline, taken by another): its
    // report would be refused, so it stops.
    if (t->second->state != State::kLeased || t->second->worker != worker) {
      cancelled->push_back(id);
      continue;
    }
    auto j = jobs_.find(t->second->spec.job);
    if (j == jobs_.end() || j->second.cancelled) {
      cancelled->push_back(id);
      continue;
    }
    t->second->expiry = now + Millis(opt_.lease_seconds);
  }
}

void Scheduler::FailAttempt(Task& t, const std::string& worker, const std::string& error) {
  ++t.attempts;
  t.error = error;
  spdlog::warn("task {} (job {}) failed on worker {} (attempt {} of {}): {}", t.spec.id, t.spec.job, worker, t.attempts,
               opt_.max_attempts, error);
  leased_.erase(t.spec.id);
  t.lease_id.clear();
  if (t.attempts >= opt_.max_attempts) {
    Quarantine(t, worker, error);
    return;
  }
  t.state = State::kQueued;
  auto j = jobs_.find(t.spec.job);
  if (j != jobs_.end()) j->second.queue.push_back(t.spec.id);
  work_cv_.notify_all();
}

Status Scheduler::Report(const std::string& worker, const std::string& id, const std::string& lease_id,
                         TaskResult result, const std::string& error, bool* duplicate) {
  *duplicate = false;
  std::unique_lock<std::mutex> l(mu_);
  ++reports_total_;
  if (auto q = quarantined_workers_.find(worker); q != quarantined_workers_.end())
    return Status::FailedPrecondition("worker " + worker + " is quarantined (" + q->second + "); report of task " + id +
                                      " ignored");
  workers_[worker] = Now();
  auto it = tasks_.find(id);
  if (it == tasks_.end()) {
    l.unlock();
    auto g = store_->Get(id);
    if (!g.ok()) return g.status();
    if (g->has_value()) {
      *duplicate = true;
      return Status::Ok();
    }
    return Status::NotFound("task " + id +
                            " is not known: its job ended, was cancelled, or the coordinator "
                            "restarted and has not rebuilt it yet");
  }
  std::shared_ptr<Task> t = it->second;
  if (t->state == State::kDone) {
    *duplicate = true;
    return Status::Ok();
  }
  if (t->state == State::kQuarantined) return Status::FailedPrecondition("task " + id + " is quarantined: " + t->error);
  // A worker whose result is held for a spot-check and that reports again (its first
  // acknowledgement was lost) gets the answer a done task gives.
  if (t->spot && Excluded(*t, worker)) {
    *duplicate = true;
    return Status::Ok();
  }
  // Only the current lease holder speaks for the task: a worker whose lease was lost
  // (and the task perhaps leased again), or that never had one, is refused, and its
  // error does not count towards quarantine.
  if (t->state != State::kLeased || lease_id.empty() || lease_id != t->lease_id) {
    ++rejected_total_;
    spdlog::warn("event=report_rejected task={} job={} worker={} reason=\"{}\"", id, t->spec.job, worker,
                 lease_id.empty() ? "no lease id" : "not the task's current lease");
    return Status::FailedPrecondition(
        "task " + id + ": the report does not hold the task's current lease (" +
        (lease_id.empty() ? std::string("no lease id given") : "lease " + lease_id + " was lost or never granted") +
        "); it was ignored");
  }
  if (!error.empty()) {
    FailAttempt(*t, worker, error);
    const std::vector<AttemptsWrite> writes = {AttemptsOf(*t)};
    l.unlock();
    WriteAttempts(writes);
    return Status::Ok();
  }
  WORMDRAG_RETURN_IF_ERROR(CheckResult(t->spec, result));
  // A spot-checked result waits for another worker's (and is then the agreed one).
  if (t->spot && !SpotCheck(*t, worker, &result)) return Status::Ok();
  const int64_t job = t->spec.job;
  l.unlock();
  // Durable before acknowledged (group commit).
  if (IsDurable(t->spec.kind)) WORMDRAG_RETURN_IF_ERROR(store_->Put(id, job, EncodeResult(result)));
  l.lock();
  if (t->state == State::kDone) {
    *duplicate = true;
    return Status::Ok();
  }
  t->state = State::kDone;
  t->result = std::move(result);
  t->lease_id.clear();
  leased_.erase(id);
  auto j = jobs_.find(job);
  if (j != jobs_.end()) ++j->second.done;
  done_cv_.notify_all();
  return Status::Ok();
}

JobTaskStats Scheduler::Stats(int64_t job) {
  std::lock_guard<std::mutex> l(mu_);
  JobTaskStats s;
  auto j = jobs_.find(job);
  if (j == jobs_.end()) return s;
  s.done = j->second.done;
  for (const auto& [id, t] : tasks_) {
    if (t->spec.job != job) continue;
    if (t->state == State::kQueued) ++s.queued;
    if (t->state == State::kLeased) ++s.leased;
  }
  return s;
}

int Scheduler::ActiveWorkers() {
  std::lock_guard<std::mutex> l(mu_);
  const auto now = Now();
  int n = 0;
  for (const auto& [w, seen] : workers_)
    if (Live(w, now)) ++n;
  return n;
}

TaskCounters Scheduler::Counters() {
  std::lock_guard<std::mutex> l(mu_);
  TaskCounters c{leases_total_, reports_total_, expired_total_, quarantined_total_, rejected_total_, 0, 0};
  c.spot_checks_total = spot_checks_total_;
  c.spot_mismatches_total = spot_mismatches_total_;
  c.workers_quarantined_total = static_cast<int64_t>(quarantined_workers_.size());
  for (const auto& [id, t] : tasks_) {
    if (t->state == State::kQueued) ++c.queued;
    if (t->state == State::kLeased) ++c.leased;
  }
  return c;
}

std::vector<QuarantinedTask> Scheduler::Quarantined() {
  std::lock_guard<std::mutex> l(mu_);
  return {quarantined_.begin(), quarantined_.end()};
}

int64_t Scheduler::rejected_reports() {
  std::lock_guard<std::mutex> l(mu_);
  return rejected_total_;
}

}  // namespace wormdrag::server
