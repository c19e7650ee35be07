// The coordinator's job store: the SQLite store with its writes put through
// StorageHealth, so a busy lock or a full disk delays a job instead of failing it.
// Reads pass straight through (in WAL mode a writer never blocks them).
#pragma once

#include <memory>

#include "core/store/job_store.h"
#include "server/storage_health.h"

namespace wormdrag::server {

class ResilientJobStore final : public JobStore {
 public:
  ResilientJobStore(std::unique_ptr<JobStore> inner, StorageHealth* health)
      : inner_(std::move(inner)), health_(health) {}

  // A submission is refused while the disk is full (RESOURCE_EXHAUSTED) rather than held.
  Status PutDataset(const DatasetRecord& d) override {
    return health_->Retry(
        "store dataset", [&] { return inner_->PutDataset(d); }, StorageHealth::WhenFull::kFail);
  }
  Result<int64_t> CreateJob(const JobRecord& job, const std::array<DatasetRecord, 2>& inputs) override {
    Result<int64_t> id = Status::Internal("unset");
    Status st = health_->Retry(
        "create job",
        [&] {
          id = inner_->CreateJob(job, inputs);
          return id.status();
        },
        StorageHealth::WhenFull::kFail);
    if (!st.ok()) return st;
    return id;
  }
  Status SetState(int64_t id, JobState s, const std::string& error) override {
    return health_->Retry("job " + std::to_string(id) + " state", [&] { return inner_->SetState(id, s, error); });
  }
  Status SetProgress(int64_t id, const std::string& phase, int64_t done, int64_t total, double best_e) override {
    return health_->Retry("job " + std::to_string(id) + " progress",
                          [&] { return inner_->SetProgress(id, phase, done, total, best_e); });
  }
  Status SetResult(int64_t id, const std::string& result_json) override {
    return health_->Retry("job " + std::to_string(id) + " result", [&] { return inner_->SetResult(id, result_json); });
  }
  Status PutEvaluations(int64_t job, const std::vector<EvaluationRecord>& batch) override {
    return health_->Retry("job " + std::to_string(job) + " evaluations",
                          [&] { return inner_->PutEvaluations(job, batch); });
  }
  Status PutSurvivors(int64_t job, int phase, const std::vector<EvaluationRecord>& ranked) override {
    return health_->Retry("job " + std::to_string(job) + " survivors",
                          [&] { return inner_->PutSurvivors(job, phase, ranked); });
  }

  Result<DatasetRecord> GetDataset(const std::string& hash) override { return inner_->GetDataset(hash); }
  Result<JobRecord> GetJob(int64_t id) override { return inner_->GetJob(id); }
  Result<std::vector<JobRecord>> ListJobs(int limit) override { return inner_->ListJobs(limit); }
  Result<std::vector<JobRecord>> JobsInState(JobState s) override { return inner_->JobsInState(s); }
  Result<std::map<JobState, int64_t>> CountJobsByState() override { return inner_->CountJobsByState(); }
  Result<std::optional<int64_t>> FindDoneJob(const std::string& eval_key, const std::string& options_json) override {
    return inner_->FindDoneJob(eval_key, options_json);
  }
  Status LookupEvaluations(const std::string& eval_key, const std::vector<Coefficients>& sets,
                           std::vector<std::optional<double>>* result) override {
    return inner_->LookupEvaluations(eval_key, sets, result);
  }
  Result<std::vector<EvaluationRecord>> Evaluations(int64_t job, int phase, int64_t limit) override {
    return inner_->Evaluations(job, phase, limit);
  }
  Result<int64_t> CountEvaluations(int64_t job, int phase) override { return inner_->CountEvaluations(job, phase); }
  Result<std::vector<EvaluationRecord>> Survivors(int64_t job, int phase) override {
    return inner_->Survivors(job, phase);
  }

 private:
  std::unique_ptr<JobStore> inner_;
  StorageHealth* health_;
};

}  // namespace wormdrag::server
