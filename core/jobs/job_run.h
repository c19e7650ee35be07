// What every job runner does around its science (estimation and diagnosis jobs,
// embedded or on the coordinator): the job's record of its two inputs, failure
// bookkeeping, progress written to the store at most twice a second, and
// cancellation read back from the store.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "core/common/status.h"
#include "core/store/job_store.h"

namespace wormdrag {

struct JobInput {
  std::string name;     // as given by the user (file name)
  std::string content;  // the kinematics file text
};

struct JobHooks {
  std::function<void(const std::string& phase, int64_t done, int64_t total, double best_e)> progress;
  std::function<bool()> cancelled;  // also polled: the job's stored state "cancelled"
};

// The dataset rows of two inputs, and the job record's dataset fields set from them.
std::array<DatasetRecord, 2> DatasetRecords(const std::array<JobInput, 2>& inputs, JobRecord* job);
// The inputs of a stored job: the names as submitted, the contents from the store.
Result<std::array<JobInput, 2>> LoadInputs(JobStore& store, const JobRecord& job);

class JobRun {
 public:
  JobRun(JobStore& store, int64_t job, JobHooks hooks) : store_(store), job_(job), hooks_(std::move(hooks)) {}
  // Records the job as cancelled (a kCancelled status) or failed, with the message;
  // returns `st`, or the store's error if recording failed.
  Status Fail(const Status& st);
  // Calls hooks.progress; writes the store at most twice a second and at done == total.
  void Progress(const std::string& phase, int64_t done, int64_t total, double best_e);
  // hooks.cancelled, or the stored state "cancelled" (read at most twice a second).
  bool Cancelled();

 private:
  JobStore& store_;
  int64_t job_;
  JobHooks hooks_;
  std::chrono::steady_clock::time_point last_store_ = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  std::chrono::steady_clock::time_point last_poll_ = std::chrono::steady_clock::now();
};

}  // namespace wormdrag
