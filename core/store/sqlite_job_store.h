// The SQLite job store behind JobStore::Open: one class, its methods split by what they
// store (the schema and connection settings in job_store_schema.cc, jobs and datasets
// in job_store.cc, evaluated sets and survivors in job_store_evaluations.cc). Internal
// to core/store.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/store/job_store.h"
#include "core/store/sqlite_handle.h"

namespace wormdrag::store_internal {

using sqlite::Database;
using sqlite::Statement;
using sqlite::Transaction;

class SqliteJobStore final : public JobStore {
 public:
  explicit SqliteJobStore(Database db) : db_(std::move(db)) {}

  // Connection settings and schema; called once by Open before the store is shared.
  Status Initialize(int busy_timeout_ms);

  Status PutDataset(const DatasetRecord& d) override;
  Result<DatasetRecord> GetDataset(const std::string& hash) override;
  Result<int64_t> CreateJob(const JobRecord& job, const std::array<DatasetRecord, 2>& inputs) override;
  Result<JobRecord> GetJob(int64_t id) override;
  Result<std::vector<JobRecord>> ListJobs(int limit) override;
  Result<std::vector<JobRecord>> JobsInState(JobState s) override;
  Result<std::map<JobState, int64_t>> CountJobsByState() override;
  Result<std::optional<int64_t>> FindDoneJob(const std::string& eval_key, const std::string& options_json) override;
  Status SetState(int64_t id, JobState s, const std::string& error) override;
  Status SetProgress(int64_t id, const std::string& phase, int64_t done, int64_t total, double best_e) override;
  Status SetResult(int64_t id, const std::string& result_json) override;
  Status PutEvaluations(int64_t job, const std::vector<EvaluationRecord>& batch) override;
  Status LookupEvaluations(const std::string& eval_key, const std::vector<Coefficients>& sets,
                           std::vector<std::optional<double>>* result) override;
  Result<std::vector<EvaluationRecord>> Evaluations(int64_t job, int phase, int64_t limit) override;
  Result<int64_t> CountEvaluations(int64_t job, int phase) override;
  Status PutSurvivors(int64_t job, int phase, const std::vector<EvaluationRecord>& ranked) override;
  Result<std::vector<EvaluationRecord>> Survivors(int64_t job, int phase) override;

 private:
  Status NotFoundJob(int64_t id) const {
    return Status::NotFound(db_.label() + ": job " + std::to_string(id) + ": not found");
  }
  Status Invalid(const std::string& message) const { return Status::InvalidArgument(db_.label() + ": " + message); }
  Status CreateOrCheckSchema();
  Status InsertDataset(const DatasetRecord& d, const std::string& created_at);
  // The job's eval_key, or NOT_FOUND. Callers hold mutex_.
  Result<std::string> JobEvalKey(int64_t id);
  // A transaction on job `id`, or NOT_FOUND when there is no such job (an unknown job
  // is an error, not an empty list). Callers hold mutex_.
  Result<Transaction> BeginOnJob(int64_t id, Transaction::Mode mode, const std::string& what);
  Result<JobRecord> ReadJob(const Statement& st) const;
  Result<std::vector<JobRecord>> QueryJobs(const std::string& sql, const std::function<void(Statement&)>& bind);
  // Runs a one-row UPDATE of job `id`; NOT_FOUND when no such job.
  Status UpdateJob(int64_t id, const std::string& sql, const std::string& what,
                   const std::function<void(Statement&)>& bind);

  // SQLite allows one writer per database anyway; serialising every call on this
  // connection also keeps statements and transactions of different threads from
  // interleaving on the one connection.
  std::mutex mutex_;
  Database db_;
};

}  // namespace wormdrag::store_internal
