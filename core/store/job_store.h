// The SQLite job store shared by embedded runs (`wormdrag estimate`) and the
// coordinator: jobs, their input recordings (content-addressed), every evaluated
// coefficient set with its E, the d1/d2 survivors and the final result.
//
// SQLite stays behind this header (SQLiteCpp style): RAII connection, statements
// and transactions live in the .cc. WAL journal, synchronous=FULL (an acknowledged
// write survives power loss), one writer (a mutex inside), foreign keys on.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/model/friction_law.h"

namespace wormdrag {

enum class JobState { kQueued, kRunning, kDone, kFailed, kCancelled };
const char* JobStateName(JobState s);  // "queued", "running", "done", "failed", "cancelled"
Result<JobState> ParseJobState(const std::string& s);

struct DatasetRecord {
  std::string hash;     // SHA-256 hex of `content`
  std::string name;     // file name as submitted
  std::string content;  // the kinematics file text
};

struct JobRecord {
  int64_t id = 0;
  std::string kind = "estimate";  // "estimate" | "diagnose"
  JobState state = JobState::kQueued;
  std::string created_at, updated_at;  // ISO 8601 UTC
  std::array<std::string, 2> dataset_hashes;
  std::array<std::string, 2> dataset_names;
  std::string options_json;               // every option, canonical JSON
  std::string eval_key;                   // hash of inputs + options that change E
  std::string phase;                      // "phase1" | "phase2" | "phase3" | "" …
  int64_t sets_done = 0, sets_total = 0;  // progress of the current phase
  double best_e = 0;                      // best E so far (mm), 0 if none
  std::string error;                      // why it failed
  std::string result_json;                // the final estimate and report
};

struct EvaluationRecord {
  int phase = 1;
  Coefficients set;
  double e = 0;  // mm; +inf where the set cannot be simulated
};

class JobStore {
 public:
  // Opens (creating if needed) the database file and its schema. A write waits up to
  // busy_timeout_ms for another connection's write lock before failing UNAVAILABLE.
  static Result<std::unique_ptr<JobStore>> Open(const std::string& path, int busy_timeout_ms = 5000);
  virtual ~JobStore() = default;

  // Datasets are immutable and addressed by hash; putting one twice is a no-op.
  virtual Status PutDataset(const DatasetRecord& d) = 0;
  virtual Result<DatasetRecord> GetDataset(const std::string& hash) = 0;

  // Inserts the job (state queued) with its datasets in one transaction; returns the id.
  virtual Result<int64_t> CreateJob(const JobRecord& job, const std::array<DatasetRecord, 2>& inputs) = 0;
  virtual Result<JobRecord> GetJob(int64_t id) = 0;
  // Newest first; `limit` 0 = all.
  virtual Result<std::vector<JobRecord>> ListJobs(int limit = 0) = 0;
  // Jobs in the given state (oldest first), e.g. to resume unfinished ones after a restart.
  virtual Result<std::vector<JobRecord>> JobsInState(JobState s) = 0;
  // How many jobs are in each state (states without jobs: 0), e.g. for monitoring.
  virtual Result<std::map<JobState, int64_t>> CountJobsByState() = 0;
  // A finished job with the same eval_key and options_json, if any (for reuse).
  virtual Result<std::optional<int64_t>> FindDoneJob(const std::string& eval_key, const std::string& options_json) = 0;

  virtual Status SetState(int64_t id, JobState s, const std::string& error = "") = 0;
  virtual Status SetProgress(int64_t id, const std::string& phase, int64_t done, int64_t total, double best_e) = 0;
  virtual Status SetResult(int64_t id, const std::string& result_json) = 0;  // also sets state done

  // Stores a batch of evaluations of one job in ONE transaction. Idempotent: a set
  // already stored for (job, phase) keeps its first value.
  virtual Status PutEvaluations(int64_t job, const std::vector<EvaluationRecord>& batch) = 0;
  // E of previously evaluated sets with the same eval_key (any job not failed nor
  // cancelled), for reuse and for resuming; result[i] empty where set i was never
  // evaluated by such a job.
  virtual Status LookupEvaluations(const std::string& eval_key, const std::vector<Coefficients>& sets,
                                   std::vector<std::optional<double>>* result) = 0;
  // The job's evaluations, best (lowest E) first; phase 0 = all phases; limit 0 = all.
  virtual Result<std::vector<EvaluationRecord>> Evaluations(int64_t job, int phase = 0, int64_t limit = 0) = 0;
  virtual Result<int64_t> CountEvaluations(int64_t job, int phase = 0) = 0;

  // The survivors of phase 1 (d1) or 2 (d2), replacing any stored before, in rank order.
  virtual Status PutSurvivors(int64_t job, int phase, const std::vector<EvaluationRecord>& ranked) = 0;
  virtual Result<std::vector<EvaluationRecord>> Survivors(int64_t job, int phase) = 0;
};

// SHA-256 of bytes, lower-case hex (for dataset hashes and eval keys).
std::string Sha256Hex(const std::string& bytes);

}  // namespace wormdrag
