// Durable task results of the coordinator, in the job store's SQLite file (its own
// table and connection). A worker's report is acknowledged only after its result
// is committed here (every kind but Phase 3's residual vectors, see IsDurable), so a coordinator killed at any moment
// loses no acknowledged result: the restarted job replays the same (content-addressed) tasks and finds them done. Rows
// of a job are deleted when the job ends.
//
// The attempts of unfinished tasks (failures reported, leases lost, the workers that
// lost them) live in the same file, so a task that kills every worker it reaches is
// quarantined after the same number of attempts whether or not the coordinator
// restarted in between.
//
// Writes are group-committed by one writer thread: every report waiting at a given
// moment goes into one transaction (one fsync), which is what lets one coordinator
// ingest thousands of results per second with synchronous=FULL.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/common/status.h"
#include "server/storage_health.h"

namespace wormdrag::server {

// Group commits of the writer thread: how many, how many results they carried, and how
// long each transaction took (begin to durable commit), as a histogram.
struct CommitStats {
  // Upper bounds of the latency buckets, seconds (the last bucket, +Inf, is `count`).
  static constexpr std::array<double, 11> kBounds = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025,
                                                     0.05,   0.1,   0.25,   0.5,   1.0};
  int64_t count = 0, results = 0;
  double seconds_sum = 0;
  std::array<int64_t, kBounds.size()> le{};  // cumulative: commits that took <= kBounds[i]
};

// What a task's earlier attempts did (see Scheduler): reported failures, lost leases
// (worker died, stalled past its lease, or ran past the task's deadline), the workers
// that lost it (comma-separated) and the last error or loss.
struct TaskAttempts {
  int failures = 0, lost = 0;
  std::string workers, last_error;
};

class TaskStore {
 public:
  // `health` (optional): a batch that meets a busy lock or a full disk is retried
  // through it (StorageHealth) instead of failing its reports, and while the disk is
  // full new results are refused UNAVAILABLE at once (workers retry them).
  static Result<std::unique_ptr<TaskStore>> Open(const std::string& path, StorageHealth* health = nullptr,
                                                 int busy_timeout_ms = 10000);
  ~TaskStore();

  // Stores the result of a task (first one wins) and returns once it is durable.
  Status Put(const std::string& task_id, int64_t job, const std::string& blob);
  // The stored result of a task, if any.
  Result<std::optional<std::string>> Get(const std::string& task_id);
  // Records a task's attempts so far (replacing what was stored). Rare (one per failure
  // or lost lease) and not group-committed.
  Status PutAttempts(const std::string& task_id, int64_t job, const TaskAttempts& a);
  // A task's stored attempts, if any.
  Result<std::optional<TaskAttempts>> GetAttempts(const std::string& task_id);
  // Forgets a finished job's results and attempts.
  Status DeleteJob(int64_t job);
  // Commits pending writes and stops the writer.
  void Close();

  int64_t commits() const { return commits_; }
  CommitStats commit_stats();

 private:
  struct Impl;
  struct Pending;
  TaskStore(std::unique_ptr<Impl> impl, StorageHealth* health);
  Status CommitBatch(const std::deque<Pending*>& batch);
  void WriterLoop();

  std::unique_ptr<Impl> impl_;
  StorageHealth* health_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Pending*> queue_;
  bool closing_ = false;
  std::thread writer_;
  int64_t commits_ = 0;
  CommitStats stats_;
};

}  // namespace wormdrag::server
