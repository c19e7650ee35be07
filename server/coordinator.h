// The coordinator's core (no gRPC here): the job store, the task store, the
// scheduler, one RunEstimateJob thread per running job, and live progress for
// watchers. services.cc translates the wire API onto this class.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include "core/jobs/diagnose_job.h"
#include "core/jobs/estimate_job.h"
#include "core/store/job_store.h"
#include "core/store/writer_lock.h"
#include "server/scheduler.h"
#include "server/storage_health.h"
#include "server/task_store.h"
#include "server/worker_activity.h"

namespace wormdrag::server {

struct CoordinatorOptions {
  std::string db_path;
  double lease_seconds = 30;
  int max_attempts = 3;
  int max_lost_leases = 3;  // SchedulerOptions
  // SQLite's wait for another connection's write lock, then StorageHealth's retries.
  int busy_timeout_ms = 5000;
  double busy_retry_seconds = 300;
  double deadline_seconds = 900, deadline_seconds_per_set = 2;
  // Most sets per task (multiple of kLanes); a call is cut into at least as many tasks
  // as there are workers (TaskSizes), so this bounds the task size for few workers.
  int chunk_sets = 128;
  // What RemoteEvaluator reports; Phase 1/2 batches are max(parallelism*32, 256) sets. 16 = an
  // embedded run with 2 threads: E is then bit-identical to `wormdrag estimate --threads 2`
  // (SIMD lane-mates change the last bits, and StoredEvaluator's reuse compacts each batch).
  int parallelism = 16;
  double spot_check_fraction = 0.02;  // SchedulerOptions
  // Jobs whose runners run at once; the others stay queued, oldest first, and start
  // as running ones end (so a burst of submissions does not hold a thread, memory and
  // a share of the workers per job).
  int max_running_jobs = 2;
  int64_t max_sets = 200000;     // largest Phase 1 grid a job may ask for
  int max_null_replicates = 50;  // largest diagnosis a job may ask for (fits grow with it)
};

struct JobProgressView {
  JobRecord job;
  JobTaskStats tasks;
  int workers = 0;
  double sets_per_second = 0;
  double eta_seconds = -1;
};

class Coordinator {
 public:
  // Takes the database's writer lock (WriterLock: refused while another coordinator
  // holds it), checks the file (PRAGMA quick_check: a damaged file is refused), then
  // opens the stores.
  static Result<std::unique_ptr<Coordinator>> Open(const CoordinatorOptions& options);
  ~Coordinator();

  // Starts every job left queued or running by an earlier coordinator.
  Status ResumeJobs();
  // Validates (job size, options, recordings) and stores the job, then starts it.
  // Nothing is stored when validation fails.
  Result<int64_t> Submit(const std::array<JobInput, 2>& inputs, const JobOptions& options, bool reuse, bool* reused);
  // A diagnosis job: the coordinator runs the base fit, its effect and null fits run
  // on workers (kDiagnoseFit tasks). Nothing is stored when validation fails.
  Result<int64_t> SubmitDiagnosis(const std::array<JobInput, 2>& inputs, const diagnose::DiagnoseOptions& options);
  Result<JobState> Cancel(int64_t job);
  Result<JobProgressView> Progress(int64_t job);
  // Blocks until something changed after `*version` or `timeout` passed; updates *version.
  void WaitForChange(uint64_t* version, std::chrono::milliseconds timeout);

  JobStore& store() { return *store_; }
  Scheduler& scheduler() { return *scheduler_; }
  TaskStore& task_store() { return *task_store_; }
  WorkerActivity& activity() { return *activity_; }
  // False while the disk of the store is full (the health service says NOT_SERVING).
  bool storage_ok() const { return !health_->full(); }
  std::chrono::system_clock::time_point started_at() const { return started_at_; }
  // Stops handing out work and flushes the task store; job threads are left blocked
  // (the process exits right after; unfinished jobs resume on the next start).
  void Shutdown();

 private:
  Coordinator() = default;
  // Starts the job's runner, or queues it while max_running_jobs runners run.
  void StartRunner(int64_t job);
  void LaunchRunner(int64_t job);
  // The runner's thread: runs the job, records how it ended and starts the next one.
  void RunJob(int64_t job);
  // The job's progress into live_ (what Progress and the watchers see).
  void RecordProgress(int64_t job, const std::string& phase, int64_t done, int64_t total, double best);
  // A job that ended: its tasks are forgotten once it is final, and the next one starts.
  void EndJob(int64_t job, const Status& st, double seconds);
  // A runner ended: starts the oldest waiting job that is still to run.
  void StartNextWaiting();
  // Runs a diagnosis job with its fits as tasks.
  Status RunDiagnosisJob(int64_t job, const JobHooks& hooks);
  void Notify();

  CoordinatorOptions opt_;
  std::unique_ptr<WriterLock> lock_;  // first member: released after the stores close
  std::unique_ptr<StorageHealth> health_;
  std::unique_ptr<JobStore> store_;
  std::unique_ptr<TaskStore> task_store_;
  std::unique_ptr<Scheduler> scheduler_;
  std::unique_ptr<WorkerActivity> activity_;
  std::chrono::system_clock::time_point started_at_ = std::chrono::system_clock::now();

  struct Live {
    std::string phase;
    int64_t done = 0, total = 0;
    double best = 0;
    std::chrono::steady_clock::time_point phase_start;
    int64_t done_at_start = 0;
  };
  std::mutex mu_;
  std::condition_variable change_cv_;
  uint64_t version_ = 0;
  std::map<int64_t, Live> live_;
  std::set<int64_t> running_;
  std::deque<int64_t> waiting_;  // queued behind max_running_jobs, oldest first
};

}  // namespace wormdrag::server
