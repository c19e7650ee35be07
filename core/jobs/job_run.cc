#include "core/jobs/job_run.h"

#include <cmath>

namespace wormdrag {

std::array<DatasetRecord, 2> DatasetRecords(const std::array<JobInput, 2>& inputs, JobRecord* job) {
  std::array<DatasetRecord, 2> ds;
  for (int j = 0; j < 2; ++j) {
    ds[j] = {Sha256Hex(inputs[j].content), inputs[j].name, inputs[j].content};
    job->dataset_hashes[j] = ds[j].hash;
    job->dataset_names[j] = inputs[j].name;
  }
  return ds;
}

Result<std::array<JobInput, 2>> LoadInputs(JobStore& store, const JobRecord& job) {
  std::array<JobInput, 2> in;
  for (int j = 0; j < 2; ++j) {
    auto d = store.GetDataset(job.dataset_hashes[j]);
    if (!d.ok()) return d.status();
    in[j] = {job.dataset_names[j], d->content};
  }
  return in;
}

Status JobRun::Fail(const Status& st) {
  const JobState s = st.code() == Status::Code::kCancelled ? JobState::kCancelled : JobState::kFailed;
  Status put = store_.SetState(job_, s, st.message());
  return put.ok() ? st : put;
}

void JobRun::Progress(const std::string& phase, int64_t done, int64_t total, double best_e) {
  if (hooks_.progress) hooks_.progress(phase, done, total, best_e);
  // Progress in the store is for watchers: at most twice a second.
  const auto now = std::chrono::steady_clock::now();
  if (done == total || now - last_store_ > std::chrono::milliseconds(500)) {
    last_store_ = now;
    (void)store_.SetProgress(job_, phase, done, total, std::isfinite(best_e) ? best_e : 0.0);
  }
}

bool JobRun::Cancelled() {
  if (hooks_.cancelled && hooks_.cancelled()) return true;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_poll_ < std::chrono::milliseconds(500)) return false;
  last_poll_ = now;
  auto j = store_.GetJob(job_);
  return j.ok() && j->state == JobState::kCancelled;
}

}  // namespace wormdrag
