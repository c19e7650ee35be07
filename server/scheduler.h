// The coordinator's task scheduler: queues of tasks per job, leases with expiry,
// heartbeats, idempotent results, quarantine, cancellation and fair sharing.
//
//  - A job's evaluator (RemoteEvaluator) submits the tasks of one Evaluate call with
//    Run() and blocks until every task has a result, a task is quarantined, or the
//    job is cancelled.
//  - Workers Lease() (long poll), Heartbeat() and Report(). Leasing goes round-robin
//    over the jobs that have queued tasks, so several jobs share the workers fairly.
//  - A lease not renewed within lease_seconds expires, and a lease still held at the
//    task's execution deadline (DeadlineFor, from the lease) is revoked however it
//    was renewed: either
//    way the lease is lost, the task goes back to the front of its queue and its lost
//    leases are counted. A task that loses max_lost_leases leases (it kills or stalls
//    every worker that takes it) is quarantined naming those workers. A reported
//    error counts separately; after max_attempts errors the task is quarantined with
//    its error. Either quarantine fails the waiting Run(), and so the job. Both counts
//    are kept in the TaskStore, so they survive a coordinator restart.
//  - Every lease has an id; a report is accepted only with the id of the task's
//    current lease (a worker whose lease was lost or never existed is refused,
//    without counting towards quarantine). A task already done answers any report as
//    a duplicate.
//  - The first valid result wins and is made durable (TaskStore) before it is
//    acknowledged; later reports of the same task are acknowledged as duplicates.
//    Residual vectors (Phase 3's Gauss–Newton stencils) are the exception: they are
//    kept in memory only (IsDurable).
//  - A deterministic fraction of E and residual tasks is spot-checked (spot_check.h,
//    scheduler_spot.cc): the result is held back until a second worker's agrees; a
//    third decides between two that disagree and the odd one out is quarantined
//    (its leases revoked, its lease requests and reports refused).
//  - Workers silent for worker_forget_leases lease periods leave the registry.
//  - Time (lease expiry, deadlines, worker liveness) comes from an injected Clock.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "core/common/status.h"
#include "core/model/friction_law.h"
#include "server/clock.h"
#include "server/task_store.h"

namespace wormdrag::server {

enum class TaskKind {
  kMeanDistance = 1,
  kMeanSquaredDistance = 2,
  kResiduals = 3,
  kDiagnoseFit = 4,
  kBootstrapReplicate = 5,
  kResidualJacobians = 6,
};

struct TaskSpec {
  std::string id;
  int64_t job = 0;
  bool screening = true;
  TaskKind kind = TaskKind::kMeanDistance;
  std::vector<Coefficients> sets;
  std::string payload;  // kDiagnoseFit, kBootstrapReplicate: the task (JSON); no sets
  // kMeanDistance with early abandoning (keep > 0): the phase keeps `keep` sets and its
  // cut was `cut` when the task was made; the result may hold kAbandoned (NaN).
  int64_t keep = 0;
  double cut = std::numeric_limits<double>::infinity();
  // kMeanDistance / kMeanSquaredDistance of a search that keeps only each group's best
  // set (Phase 3's scale rays; EvaluationRequest::set_cuts): per set, its group's cut
  // when the task was made and its group (an index below sets.size()), or both empty.
  // The result may hold kAbandoned for a set proven above its group's cut.
  std::vector<double> set_cuts;
  std::vector<int32_t> set_groups;
  // 0: both worms; 1 or 2: only that worm's share (E kinds without a cut, residual
  // kinds): distance sums per set, or that worm's residual rows (RemoteEvaluator).
  int worm = 0;
  // Whether the result may hold kAbandoned: the task carries the phase's cut or group cuts.
  bool may_abandon() const { return keep > 0 || !set_cuts.empty(); }
  // Units of progress: sets, or one per diagnosis fit or bootstrap refit.
  int64_t units() const {
    return kind == TaskKind::kDiagnoseFit || kind == TaskKind::kBootstrapReplicate ? 1
                                                                                   : static_cast<int64_t>(sets.size());
  }
};

// Whether a task's result is written to the TaskStore before it is acknowledged.
// Residual vectors are not: one per set of frames × points numbers (19 KB per set for
// a 2 s × 100 fps pair, ~150 KB at 5 s × 300 fps), they made a job's Phase 3 write
// 0.3–3 GB, which cost every job a fifth of the service's Phase 3 time
// (BENCHMARKS.md), while all they saved was rerunning Phase 3 after a coordinator
// restart (the stored Phases 1–2 are reused either way). E values and diagnosis fits
// stay durable. A late report of a residual task whose call has ended gets NOT_FOUND.
// Residuals with their Jacobians (five times the size) are not durable either.
inline bool IsDurable(TaskKind kind) {
  return kind != TaskKind::kResiduals && kind != TaskKind::kResidualJacobians;
}

// values (one per set) for E kinds, residuals (one vector per set) for kResiduals and
// kResidualJacobians, with (the latter) one Jacobian per residual vector in
// `jacobians` (4 columns, column-major), the fit outcome's numbers for kDiagnoseFit.
struct TaskResult {
  std::vector<double> values;
  std::vector<std::vector<double>> residuals, jacobians;
  int64_t knots = 0, knots_full = 0;  // E kinds: solver knots simulated, and without abandoning
  int worm = 0;                       // the TaskSpec::worm the worker answered
};
std::string EncodeResult(const TaskResult& r);
bool DecodeResult(const std::string& blob, TaskResult* r);
// InvalidArgument unless `result` has the form task `spec` asks for.
Status CheckResult(const TaskSpec& spec, const TaskResult& result);

// Deterministic, content-addressed task id (see RemoteEvaluator).
std::string MakeTaskId(int64_t job, bool screening, TaskKind kind, const Coefficients* sets, size_t count,
                       const std::string& payload = "");

// What a worker needs to know about a task's job.
struct JobInfo {
  std::array<std::string, 2> dataset_hashes, dataset_names;
  std::string options_json;
};

struct LeasedTask {
  TaskSpec spec;
  JobInfo job;
  std::string lease_id;  // a report must carry it
};

struct SchedulerOptions {
  double lease_seconds = 30;
  int max_attempts = 3;     // reported errors before a task is quarantined
  int max_lost_leases = 3;  // leases lost (worker died or stalled, deadline) before it is
  // A task's execution deadline, from each lease: deadline_seconds plus
  // deadline_seconds_per_set for each coefficient set it carries (DeadlineFor).
  double deadline_seconds = 900;
  double deadline_seconds_per_set = 2;
  // Fraction of spot-checked tasks (0 = none; IsSpotChecked), and how far two
  // workers' numbers may differ, relative: 1e-12 is ~4500 units in the last place,
  // far above the last-bit differences of another CPU or libm over a simulation's
  // thousands of steps, and far below any error that could change a ranking.
  double spot_check_fraction = 0.02;
  double spot_check_tolerance = 1e-12;
  // A worker not heard from for this many lease periods is dropped from the registry
  // (ActiveWorkers, Workers); it is registered again when it calls.
  double worker_forget_leases = 10;
  const Clock* clock = nullptr;  // null: Clock::Real()
  // worker_forget_leases lease periods; the status page's worker list uses it too.
  std::chrono::milliseconds WorkerForgetAfter() const {
    return std::chrono::milliseconds(static_cast<int64_t>(worker_forget_leases * lease_seconds * 1000));
  }
  // Whether a thread calls ReapExpired() every 200 ms; tests with a hand-moved clock
  // call it themselves.
  bool reaper_thread = true;
};

// The execution deadline of a task, seconds from its lease.
double DeadlineFor(const TaskSpec& spec, const SchedulerOptions& o);

struct JobTaskStats {
  int64_t queued = 0, leased = 0, done = 0;
};

// Since the coordinator started (totals) and now (queued, leased), over all jobs.
struct TaskCounters {
  int64_t leased_total = 0, reports_total = 0, expired_total = 0, quarantined_total = 0, rejected_total = 0;
  int64_t queued = 0, leased = 0;
  int64_t spot_checks_total = 0, spot_mismatches_total = 0, workers_quarantined_total = 0;
};

// A task taken out of service after max_attempts failures (its job then fails).
struct QuarantinedTask {
  std::string task_id, worker, error;  // worker: the last; for lost leases, every one
  int64_t job = 0;
  int attempts = 0;
  std::chrono::system_clock::time_point at;
};

class Scheduler {
 public:
  Scheduler(TaskStore* store, SchedulerOptions options);
  ~Scheduler();

  // Makes a job's tasks leasable (idempotent).
  void AddJob(int64_t job, const JobInfo& info);
  // Forgets a finished job.
  void RemoveJob(int64_t job);
  // Cancels a job: its waiting Run() returns CANCELLED, its tasks are dropped and
  // heartbeats tell workers to stop them.
  void CancelJob(int64_t job);
  bool IsCancelled(int64_t job);

  // Submits tasks and waits for all their results (in order). Tasks with a stored
  // result are answered without a worker. `progress(sets_done)` is called as
  // results come in.
  Status Run(int64_t job, std::vector<TaskSpec> tasks, std::vector<TaskResult>* results,
             const std::function<void(int64_t)>& progress);

  // Worker side. Lease waits up to `wait` for a task; false when there is none.
  bool Lease(const std::string& worker, std::chrono::milliseconds wait, LeasedTask* out);
  void Heartbeat(const std::string& worker, const std::vector<std::string>& task_ids,
                 std::vector<std::string>* cancelled);
  // Records a result (error empty) or a failure from the holder of lease `lease_id`.
  // NOT_FOUND for an unknown task, FAILED_PRECONDITION for a report without the
  // task's current lease (nothing is counted), INVALID_ARGUMENT for a result of the
  // wrong shape or with values that are not finite and >= 0.
  Status Report(const std::string& worker, const std::string& task_id, const std::string& lease_id, TaskResult result,
                const std::string& error, bool* duplicate);
  // Revokes leases past their expiry or their task's deadline (the reaper thread's
  // work, every 200 ms).
  void ReapExpired();

  JobTaskStats Stats(int64_t job);
  // Workers heard from within the last lease period (or waiting in Lease now).
  int ActiveWorkers();
  // The registry: every worker heard from within worker_forget_leases lease periods.
  std::vector<std::string> Workers();
  // Whether a spot-check quarantined `worker`; why, in *reason.
  bool WorkerQuarantined(const std::string& worker, std::string* reason);
  // Every quarantined worker with why.
  std::map<std::string, std::string> QuarantinedWorkers();
  double lease_seconds() const { return opt_.lease_seconds; }
  int64_t leases() const { return leases_total_; }
  int64_t reports() const { return reports_total_; }
  // Reports refused for not holding the task's lease.
  int64_t rejected_reports();
  TaskCounters Counters();
  // The most recently quarantined tasks, oldest first (at most kQuarantineKept).
  std::vector<QuarantinedTask> Quarantined();
  static constexpr size_t kQuarantineKept = 50;
  // Wakes every waiter with UNAVAILABLE and refuses new work (shutdown).
  void Stop();

 private:
  enum class State { kQueued, kLeased, kDone, kQuarantined };
  struct Task {
    TaskSpec spec;
    State state = State::kQueued;
    int attempts = 0;  // reported errors
    int lost = 0;      // leases lost
    std::string error;
    std::string lost_by;  // workers that lost a lease of it, comma-separated
    TaskResult result;
    std::string worker, lease_id;
    Clock::time_point expiry, deadline;  // of the current lease
    int waiters = 0;                     // Run() calls holding it
    // Spot-checked (IsSpotChecked): results held back, with their workers, until two
    // agree. A worker that gave one is not leased the task again.
    bool spot = false;
    std::vector<std::pair<std::string, TaskResult>> candidates;
  };
  struct AttemptsWrite {
    std::string id;
    int64_t job;
    TaskAttempts attempts;
  };
  struct JobQueue {
    JobInfo info;
    std::deque<std::string> queue;
    bool cancelled = false;
    int64_t done = 0;
  };
  void ReaperLoop();
  // Under mu_: quarantines `t` and records it.
  void Quarantine(Task& t, const std::string& worker, const std::string& reason);
  // A reported error: one more attempt; the task is queued again or, at the last
  // attempt, quarantined. Caller holds mu_.
  void FailAttempt(Task& t, const std::string& worker, const std::string& error);
  // Under mu_: a lost lease of `t` (counted; quarantine at max_lost_leases).
  void LoseLease(Task& t, const std::string& why, std::vector<AttemptsWrite>* writes);
  static AttemptsWrite AttemptsOf(const Task& t);
  // Without mu_: each task's durable result, or else its attempts, from the store.
  Status LoadStored(const std::vector<TaskSpec>& tasks, std::vector<std::optional<TaskResult>>* stored,
                    std::vector<std::optional<TaskAttempts>>* attempts);
  // Under mu_: the shared entry of each task, made (done, queued on `queue` or
  // quarantined) where it is new; each gets one more waiter.
  std::vector<std::shared_ptr<Task>> Hold(std::vector<TaskSpec> tasks, std::vector<std::optional<TaskResult>> stored,
                                          const std::vector<std::optional<TaskAttempts>>& attempts,
                                          std::deque<std::string>* queue);
  // Under mu_: one waiter less on each; a task nobody waits for is forgotten.
  void Release(const std::vector<std::shared_ptr<Task>>& mine);
  // Why a quarantined task ended its job.
  Status QuarantineStatus(const Task& t) const;
  // Without mu_: stores attempt counts (logged, not fatal, when it fails).
  void WriteAttempts(const std::vector<AttemptsWrite>& writes);
  Clock::time_point Now() const { return clock_->Now(); }
  // Spot-checks (scheduler_spot.cc), all under mu_. SpotCheck takes the holder's
  // valid result of a spot-checked task: true when *result is now the task's result
  // to store, false when the task went back to the queue for another opinion (or
  // was quarantined).
  bool SpotCheck(Task& t, const std::string& worker, TaskResult* result);
  bool Excluded(const Task& t, const std::string& worker) const;
  bool OtherLiveWorker(const Task& t);
  static constexpr double kSpotCheckRecentSeconds = 5;
  bool Live(const std::string& worker, Clock::time_point now) const;
  void Requeue(Task& t);
  void QuarantineWorker(const std::string& worker, const std::string& reason);
  // The reaper's part: spot-checks nobody can give a second opinion on are dropped;
  // silent workers leave the registry.
  void ReviewSpotChecks();
  void ForgetSilentWorkers();

  TaskStore* store_;
  SchedulerOptions opt_;
  const Clock* clock_;
  uint64_t lease_salt_ = 0;  // differs per coordinator start: old lease ids never match
  uint64_t lease_seq_ = 0;
  std::mutex mu_;
  std::condition_variable work_cv_, done_cv_;
  std::unordered_map<std::string, std::shared_ptr<Task>> tasks_;
  std::map<int64_t, JobQueue> jobs_;
  std::set<std::string> leased_;
  int64_t rr_cursor_ = 0;
  std::unordered_map<std::string, Clock::time_point> workers_;
  std::unordered_map<std::string, int> polling_;            // Lease calls waiting, per worker
  std::map<std::string, std::string> quarantined_workers_;  // worker -> reason
  std::set<std::string> spot_pending_;                      // tasks back in the queue for another opinion
  int64_t spot_checks_total_ = 0, spot_mismatches_total_ = 0;
  bool stopping_ = false;
  std::thread reaper_;
  int64_t leases_total_ = 0, reports_total_ = 0, expired_total_ = 0, rejected_total_ = 0;
  std::deque<QuarantinedTask> quarantined_;
  int64_t quarantined_total_ = 0;
};

}  // namespace wormdrag::server
