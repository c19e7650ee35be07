// What the coordinator sees of its workers, for the status page and /metrics: every
// WorkerService call (lease poll, heartbeat, report) is a sign of life, and reported
// results give each worker's throughput and the service's sets per second. Fed by the
// gRPC services; nothing here changes how tasks are scheduled.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "server/clock.h"

namespace wormdrag::server {

struct WorkerView {
  std::string id;
  int threads = 0;                   // as the worker announced in its lease requests
  double seconds_since_contact = 0;  // its last call of any kind
  int64_t tasks_done = 0, tasks_failed = 0, sets_done = 0;
  double sets_per_second = 0;  // over the last WorkerActivity::kRateWindow
  std::string task;            // leased and not reported yet; "" = idle
};

class WorkerActivity {
 public:
  using time_point = Clock::time_point;
  // Rates are averaged over this window. Default: 20 s, several Phase 1 tasks long, so
  // a worker between two tasks does not read as stalled.
  static constexpr std::chrono::seconds kRateWindow{20};

  // Workers silent for longer than `forget_after` are dropped from the list. The
  // coordinator passes the scheduler's registry expiry (SchedulerOptions::
  // WorkerForgetAfter, 10 lease periods), so the page lists the workers the scheduler
  // still knows, and a drained or killed worker stays visible a while after it left.
  // `clock`: null for Clock::Real(); tests move one by hand.
  explicit WorkerActivity(std::chrono::milliseconds forget_after, const Clock* clock = nullptr);
  std::chrono::milliseconds forget_after() const { return forget_after_; }

  void Polled(const std::string& worker, int threads);
  // `units`: sets of the task (one per diagnosis fit).
  void Leased(const std::string& worker, const std::string& task, int64_t units);
  void Heartbeat(const std::string& worker);
  // A report the scheduler accepted (not a duplicate): a result or a failure.
  // `units_if_unknown` counts a report of a task this worker is not known to hold.
  void Reported(const std::string& worker, const std::string& task, bool failed, int64_t units_if_unknown);

  // Most recently heard from first.
  std::vector<WorkerView> Workers();
  double SetsPerSecond();
  int64_t sets_total();

 private:
  struct Worker {
    int threads = 0;
    time_point first_contact, last_contact;
    int64_t tasks_done = 0, tasks_failed = 0, sets_done = 0;
    std::deque<std::pair<time_point, int64_t>> recent;  // reports in the window
    std::string task;
    int64_t task_units = 0;
  };
  Worker& Touch(const std::string& worker, time_point now);
  static void Prune(std::deque<std::pair<time_point, int64_t>>* recent, time_point now);
  static double Rate(std::deque<std::pair<time_point, int64_t>>* recent, time_point since, time_point now);

  const std::chrono::milliseconds forget_after_;
  const Clock& clock_;
  std::mutex mu_;
  std::map<std::string, Worker> workers_;
  std::deque<std::pair<time_point, int64_t>> recent_;  // all workers
  time_point started_;
  int64_t sets_total_ = 0;
};

}  // namespace wormdrag::server
