#include "server/coordinator.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include <spdlog/spdlog.h>

#include "core/common/guard.h"
#include "core/jobs/bootstrap_run.h"
#include "core/sim/simulator.h"
#include "server/remote_evaluator.h"
#include "server/resilient_job_store.h"

namespace wormdrag::server {

Result<std::unique_ptr<Coordinator>> Coordinator::Open(const CoordinatorOptions& o) {
  if (o.chunk_sets < kLanes || o.chunk_sets % kLanes != 0)
    return Status::InvalidArgument("--chunk-sets must be a positive multiple of " + std::to_string(kLanes));
  if (!(o.lease_seconds >= 1)) return Status::InvalidArgument("--lease-seconds must be >= 1");
  if (o.max_attempts < 1) return Status::InvalidArgument("--max-attempts must be >= 1");
  if (o.max_lost_leases < 1) return Status::InvalidArgument("--max-lost-leases must be >= 1");
  if (!(o.spot_check_fraction >= 0 && o.spot_check_fraction <= 1))
    return Status::InvalidArgument("--spot-check-fraction must be between 0 and 1");
  if (o.max_running_jobs < 1) return Status::InvalidArgument("--max-running-jobs must be >= 1");
  if (!(o.deadline_seconds >= 1) || !(o.deadline_seconds_per_set >= 0))
    return Status::InvalidArgument("--task-deadline must be >= 1 s and its per-set part >= 0");
  std::unique_ptr<Coordinator> c(new Coordinator());
  c->opt_ = o;
  // One coordinator per file, and only on a sound file: both before anything writes.
  auto lock = WriterLock::Acquire(o.db_path);
  if (!lock.ok()) return lock.status();
  c->lock_ = std::move(*lock);
  WORMDRAG_RETURN_IF_ERROR(CheckDatabaseIntegrity(o.db_path));
  c->health_ = std::make_unique<StorageHealth>(
      std::chrono::milliseconds(static_cast<int64_t>(o.busy_retry_seconds * 1000)));
  auto store = JobStore::Open(o.db_path, o.busy_timeout_ms);
  if (!store.ok()) return store.status();
  c->store_ = std::make_unique<ResilientJobStore>(std::move(*store), c->health_.get());
  auto ts = TaskStore::Open(o.db_path, c->health_.get(), o.busy_timeout_ms);
  if (!ts.ok()) return ts.status();
  c->task_store_ = std::move(*ts);
  SchedulerOptions so{o.lease_seconds, o.max_attempts, o.max_lost_leases, o.deadline_seconds,
                      o.deadline_seconds_per_set};
  so.spot_check_fraction = o.spot_check_fraction;
  c->scheduler_ = std::make_unique<Scheduler>(c->task_store_.get(), so);
  c->activity_ = std::make_unique<WorkerActivity>(so.WorkerForgetAfter());
  return c;
}

Coordinator::~Coordinator() {
  if (scheduler_) scheduler_->Stop();
  if (health_) health_->Stop();
  Shutdown();
}

void Coordinator::Shutdown() {
  // The scheduler is not stopped: waking the job threads would make RunEstimateJob
  // record their jobs as failed. They stay blocked and the process exits; every
  // acknowledged result is already durable, so the next start resumes them.
  if (task_store_) task_store_->Close();
}

void Coordinator::Notify() {
  std::lock_guard<std::mutex> l(mu_);
  ++version_;
  change_cv_.notify_all();
}

void Coordinator::WaitForChange(uint64_t* version, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> l(mu_);
  change_cv_.wait_for(l, timeout, [&] { return version_ != *version; });
  *version = version_;
}

Status Coordinator::ResumeJobs() {
  for (JobState s : {JobState::kRunning, JobState::kQueued}) {
    auto jobs = store_->JobsInState(s);
    if (!jobs.ok()) return jobs.status();
    for (const auto& j : *jobs) {
      spdlog::info("event=job_resumed job={} state={} phase={}", j.id, JobStateName(j.state), j.phase);
      StartRunner(j.id);
    }
  }
  return Status::Ok();
}

Result<int64_t> Coordinator::Submit(const std::array<JobInput, 2>& inputs, const JobOptions& options, bool reuse,
                                    bool* reused) {
  const double grid = std::pow(options.estimate.search.n_max + 1.0, 4);
  if (grid > static_cast<double>(opt_.max_sets))
    return Status::ResourceExhausted("job too large: the Phase 1 grid has " +
                                     std::to_string(static_cast<int64_t>(grid)) + " sets (n_max " +
                                     std::to_string(options.estimate.search.n_max) + "); this server accepts at most " +
                                     std::to_string(opt_.max_sets));
  auto id = SubmitEstimateJob(*store_, inputs, options, reuse, reused);
  if (!id.ok()) return id.status();
  spdlog::info("event=job_submitted job={} reused={} grid_sets={} inputs={},{}", *id, *reused,
               static_cast<int64_t>(grid), inputs[0].name, inputs[1].name);
  if (!*reused) StartRunner(*id);
  Notify();
  return *id;
}

Result<int64_t> Coordinator::SubmitDiagnosis(const std::array<JobInput, 2>& inputs,
                                             const diagnose::DiagnoseOptions& options) {
  if (options.null_replicates > opt_.max_null_replicates)
    return Status::ResourceExhausted("job too large: " + std::to_string(options.null_replicates) +
                                     " null replicates; this server accepts at most " +
                                     std::to_string(opt_.max_null_replicates));
  auto id = SubmitDiagnoseJob(*store_, inputs, options);
  if (!id.ok()) return id.status();
  spdlog::info("event=job_submitted job={} kind=diagnose null_replicates={} inputs={},{}", *id, options.null_replicates,
               inputs[0].name, inputs[1].name);
  StartRunner(*id);
  Notify();
  return *id;
}

namespace {

// A task of the job whose whole input is its payload (a fit, a bootstrap refit).
TaskSpec PayloadTask(int64_t job, TaskKind kind, std::string payload) {
  TaskSpec t;
  t.job = job;
  t.screening = false;
  t.kind = kind;
  t.payload = std::move(payload);
  t.id = MakeTaskId(job, false, t.kind, nullptr, 0, t.payload);
  return t;
}

// Bootstrap refits go to the workers too, one task per refit.
ReplicateRunner RemoteReplicates(Scheduler& sched, int64_t id) {
  return [&sched, id](const PairedPath&, const std::vector<ReplicateTask>& tasks, const JobOptions&,
                      const std::function<void(int, int)>& progress,
                      const std::function<bool()>&) -> Result<std::vector<std::optional<ScoredSet>>> {
    const int n = static_cast<int>(tasks.size());
    std::vector<TaskSpec> specs;
    for (const ReplicateTask& task : tasks) {
      specs.push_back(PayloadTask(id, TaskKind::kBootstrapReplicate, ReplicateTaskToJson(task)));
    }
    std::vector<TaskResult> results;
    WORMDRAG_RETURN_IF_ERROR(
        sched.Run(id, std::move(specs), &results, [&](int64_t done) { progress(static_cast<int>(done), n); }));
    std::vector<std::optional<ScoredSet>> fits(n);
    for (int r = 0; r < n; ++r) {
      const auto& v = results[r].values;  // RunReplicateTask's values
      if (v.size() == 6 && v[0] == 1) fits[r] = ScoredSet{{v[1], v[2], v[3], v[4]}, v[5]};
    }
    return fits;
  };
}

}  // namespace

Status Coordinator::RunDiagnosisJob(int64_t id, const JobHooks& hooks) {
  auto job = store_->GetJob(id);
  if (!job.ok()) return job.status();
  scheduler_->AddJob(id, JobInfo{job->dataset_hashes, job->dataset_names, job->options_json});
  JobRun run(*store_, id, hooks);
  diagnose::FitRunner runner =
      [&](const std::vector<diagnose::FitTask>& fits) -> Result<std::vector<diagnose::FitOutcome>> {
    std::vector<TaskSpec> specs;
    for (const auto& f : fits) specs.push_back(PayloadTask(id, TaskKind::kDiagnoseFit, FitTaskToJson(f)));
    const int64_t total = static_cast<int64_t>(specs.size());
    const std::string stage = total == 1 ? "base fit" : "fits";
    std::vector<TaskResult> results;
    WORMDRAG_RETURN_IF_ERROR(
        scheduler_->Run(id, std::move(specs), &results, [&](int64_t done) { run.Progress(stage, done, total, 0); }));
    std::vector<diagnose::FitOutcome> out;
    for (size_t i = 0; i < fits.size(); ++i) {
      auto f = FitOutcomeFromValues(results[i].values, fits[i]);
      if (!f.ok()) return f.status();
      out.push_back(std::move(*f));
    }
    return out;
  };
  return RunDiagnoseJob(*store_, id, runner, /*threads=*/0, hooks);
}

Result<JobState> Coordinator::Cancel(int64_t id) {
  auto job = store_->GetJob(id);
  if (!job.ok()) return job.status();
  if (job->state == JobState::kDone || job->state == JobState::kFailed || job->state == JobState::kCancelled)
    return Status::FailedPrecondition("job " + std::to_string(id) + " has already ended (" + JobStateName(job->state) +
                                      ")");
  WORMDRAG_RETURN_IF_ERROR(store_->SetState(id, JobState::kCancelled, "cancelled by user"));
  scheduler_->CancelJob(id);
  spdlog::info("event=job_cancelled job={}", id);
  Notify();
  return JobState::kCancelled;
}

void Coordinator::StartRunner(int64_t id) {
  bool start = false;
  {
    std::lock_guard<std::mutex> l(mu_);
    if (running_.count(id) || std::find(waiting_.begin(), waiting_.end(), id) != waiting_.end()) return;
    if (static_cast<int>(running_.size()) < opt_.max_running_jobs) {
      running_.insert(id);
      start = true;
    } else {
      waiting_.push_back(id);
      spdlog::info("event=job_waiting job={} running={} max_running_jobs={}", id, running_.size(),
                   opt_.max_running_jobs);
    }
  }
  if (start) return LaunchRunner(id);
  // A job resumed as running after a restart waits as queued, which it is.
  auto job = store_->GetJob(id);
  if (job.ok() && job->state == JobState::kRunning) (void)store_->SetState(id, JobState::kQueued);
}

void Coordinator::StartNextWaiting() {
  for (;;) {
    int64_t next;
    {
      std::lock_guard<std::mutex> l(mu_);
      if (waiting_.empty() || static_cast<int>(running_.size()) >= opt_.max_running_jobs) return;
      next = waiting_.front();
      waiting_.pop_front();
      running_.insert(next);
    }
    // Cancelled while it waited: nothing to run.
    auto job = store_->GetJob(next);
    if (!job.ok() || job->state != JobState::kQueued) {
      std::lock_guard<std::mutex> l(mu_);
      running_.erase(next);
      continue;
    }
    spdlog::info("event=job_dequeued job={}", next);
    LaunchRunner(next);
  }
}

void Coordinator::LaunchRunner(int64_t id) {
  std::thread([this, id] { RunJob(id); }).detach();
}

void Coordinator::RecordProgress(int64_t id, const std::string& phase, int64_t done, int64_t total, double best) {
  {
    std::lock_guard<std::mutex> l(mu_);
    Live& v = live_[id];
    const auto now = std::chrono::steady_clock::now();
    if (v.phase != phase || done < v.done) {
      v.phase = phase;
      v.phase_start = now;
      v.done_at_start = done;
    }
    v.done = done;
    v.total = total;
    v.best = std::isfinite(best) ? best : 0;
    ++version_;
  }
  change_cv_.notify_all();
}

void Coordinator::RunJob(int64_t id) {
  const int chunk = opt_.chunk_sets, par = opt_.parallelism;
  Scheduler& sched = *scheduler_;
  EvaluatorFactory factory = [&sched, chunk, par](const JobRecord& job, std::shared_ptr<const PairedPath> pair,
                                                  const EvaluationOptions&,
                                                  bool screening) -> Result<std::unique_ptr<BatchEvaluator>> {
    sched.AddJob(job.id, JobInfo{job.dataset_hashes, job.dataset_names, job.options_json});
    return std::unique_ptr<BatchEvaluator>(new RemoteEvaluator(sched, std::move(pair), job.id, screening, chunk, par));
  };
  JobHooks hooks;
  hooks.progress = [this, id](const std::string& phase, int64_t done, int64_t total, double best) {
    RecordProgress(id, phase, done, total, best);
  };
  hooks.cancelled = [&sched, id] { return sched.IsCancelled(id); };
  const ReplicateRunner replicates = RemoteReplicates(sched, id);
  spdlog::info("event=job_started job={}", id);
  const auto t0 = std::chrono::steady_clock::now();
  // The runner's thread boundary: an exception that escapes the runner (a bug, or
  // memory exhausted) fails the job with the reason instead of aborting the process,
  // so a restart does not resume it into the same crash.
  bool escaped = true;
  Status st = RunGuarded("job " + std::to_string(id) + " runner", [&]() -> Status {
    auto rec = store_->GetJob(id);
    Status s = rec.ok() && rec->kind == "diagnose" ? RunDiagnosisJob(id, hooks)
                                                   : RunEstimateJob(*store_, id, factory, hooks, replicates);
    escaped = false;
    return s;
  });
  if (escaped) {
    spdlog::error("event=job_runner_threw job={} error=\"{}\"", id, st.message());
    if (Status put = store_->SetState(id, JobState::kFailed, st.message()); !put.ok())
      spdlog::error("event=job_fail_not_recorded job={} error=\"{}\"", id, put.message());
    scheduler_->CancelJob(id);
  }
  EndJob(id, st, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void Coordinator::EndJob(int64_t id, const Status& st, double secs) {
  if (st.code() == Status::Code::kUnavailable) {
    // Shutting down: the job stays resumable; the process is about to exit.
    spdlog::info("event=job_interrupted job={} reason=\"{}\"", id, st.message());
    return;
  }
  if (st.ok())
    spdlog::info("event=job_done job={} seconds={:.2f}", id, secs);
  else
    spdlog::warn("event=job_ended job={} status={} error=\"{}\"", id, CodeName(st.code()), st.message());
  auto job = store_->GetJob(id);
  if (job.ok() &&
      (job->state == JobState::kDone || job->state == JobState::kFailed || job->state == JobState::kCancelled)) {
    (void)task_store_->DeleteJob(id);
    scheduler_->RemoveJob(id);
  }
  {
    std::lock_guard<std::mutex> l(mu_);
    running_.erase(id);
    live_.erase(id);
    ++version_;
  }
  change_cv_.notify_all();
  StartNextWaiting();
}

Result<JobProgressView> Coordinator::Progress(int64_t id) {
  auto job = store_->GetJob(id);
  if (!job.ok()) return job.status();
  JobProgressView v;
  v.job = std::move(*job);
  v.tasks = scheduler_->Stats(id);
  v.workers = scheduler_->ActiveWorkers();
  std::lock_guard<std::mutex> l(mu_);
  auto it = live_.find(id);
  if (it != live_.end() && v.job.state == JobState::kRunning) {
    const Live& lv = it->second;
    v.job.phase = lv.phase;
    v.job.sets_done = lv.done;
    v.job.sets_total = lv.total;
    v.job.best_e = lv.best;
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - lv.phase_start).count();
    if (dt > 0.2 && lv.done > lv.done_at_start) {
      v.sets_per_second = static_cast<double>(lv.done - lv.done_at_start) / dt;
      v.eta_seconds = static_cast<double>(lv.total - lv.done) / v.sets_per_second;
    }
  }
  return v;
}

}  // namespace wormdrag::server
