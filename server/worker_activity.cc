#include "server/worker_activity.h"

#include <algorithm>

namespace wormdrag::server {

WorkerActivity::WorkerActivity(std::chrono::milliseconds forget_after, const Clock* clock)
    : forget_after_(forget_after), clock_(clock ? *clock : Clock::Real()), started_(clock_.Now()) {}

WorkerActivity::Worker& WorkerActivity::Touch(const std::string& id, time_point now) {
  auto [it, added] = workers_.try_emplace(id);
  it->second.last_contact = now;
  if (added) {
    it->second.first_contact = now;
    // Bounded: every new id (a restarted worker's, say) sweeps out the long-silent ones.
    for (auto w = workers_.begin(); w != workers_.end();)
      w = now - w->second.last_contact > forget_after_ ? workers_.erase(w) : std::next(w);
  }
  return it->second;
}

void WorkerActivity::Polled(const std::string& worker, int threads) {
  std::lock_guard<std::mutex> l(mu_);
  Touch(worker, clock_.Now()).threads = threads;
}

void WorkerActivity::Leased(const std::string& worker, const std::string& task, int64_t units) {
  std::lock_guard<std::mutex> l(mu_);
  Worker& w = Touch(worker, clock_.Now());
  w.task = task;
  w.task_units = units;
}

void WorkerActivity::Heartbeat(const std::string& worker) {
  std::lock_guard<std::mutex> l(mu_);
  Touch(worker, clock_.Now());
}

void WorkerActivity::Reported(const std::string& worker, const std::string& task, bool failed,
                              int64_t units_if_unknown) {
  std::lock_guard<std::mutex> l(mu_);
  const auto now = clock_.Now();
  Worker& w = Touch(worker, now);
  int64_t sets = units_if_unknown;
  if (w.task == task) {
    sets = w.task_units;
    w.task.clear();
  }
  if (failed) {
    ++w.tasks_failed;
    return;
  }
  ++w.tasks_done;
  w.sets_done += sets;
  w.recent.emplace_back(now, sets);
  recent_.emplace_back(now, sets);
  Prune(&w.recent, now);
  Prune(&recent_, now);
  sets_total_ += sets;
}

void WorkerActivity::Prune(std::deque<std::pair<time_point, int64_t>>* recent, time_point now) {
  while (!recent->empty() && now - recent->front().first > kRateWindow) recent->pop_front();
}

// Sets reported within the window, per second of the window (or of the time since
// `since`, when that is shorter: a worker that just started is not averaged with
// time it did not exist).
double WorkerActivity::Rate(std::deque<std::pair<time_point, int64_t>>* recent, time_point since, time_point now) {
  Prune(recent, now);
  int64_t sets = 0;
  for (const auto& r : *recent) sets += r.second;
  const double span = std::min(std::chrono::duration<double>(kRateWindow).count(),
                               std::chrono::duration<double>(now - since).count());
  return span > 0.5 ? static_cast<double>(sets) / span : 0.0;
}

std::vector<WorkerView> WorkerActivity::Workers() {
  std::lock_guard<std::mutex> l(mu_);
  const auto now = clock_.Now();
  std::vector<WorkerView> out;
  for (auto& [id, w] : workers_) {
    if (now - w.last_contact > forget_after_) continue;
    WorkerView v;
    v.id = id;
    v.threads = w.threads;
    v.seconds_since_contact = std::chrono::duration<double>(now - w.last_contact).count();
    v.tasks_done = w.tasks_done;
    v.tasks_failed = w.tasks_failed;
    v.sets_done = w.sets_done;
    v.sets_per_second = Rate(&w.recent, w.first_contact, now);
    v.task = w.task;
    out.push_back(std::move(v));
  }
  std::stable_sort(out.begin(), out.end(), [](const WorkerView& a, const WorkerView& b) {
    return a.seconds_since_contact < b.seconds_since_contact;
  });
  return out;
}

double WorkerActivity::SetsPerSecond() {
  std::lock_guard<std::mutex> l(mu_);
  return Rate(&recent_, started_, clock_.Now());
}

int64_t WorkerActivity::sets_total() {
  std::lock_guard<std::mutex> l(mu_);
  return sets_total_;
}

}  // namespace wormdrag::server
