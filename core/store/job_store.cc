#include "core/store/job_store.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <mutex>
#include <utility>

#include "core/store/sqlite_handle.h"

namespace wormdrag {

const char* JobStateName(JobState s) {
  switch (s) {
    case JobState::kQueued:
      return "queued";
    case JobState::kRunning:
      return "running";
    case JobState::kDone:
      return "done";
    case JobState::kFailed:
      return "failed";
    case JobState::kCancelled:
      return "cancelled";
  }
  return "unknown";
}

Result<JobState> ParseJobState(const std::string& s) {
  for (JobState state :
       {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kFailed, JobState::kCancelled}) {
    if (s == JobStateName(state)) return state;
  }
  return Status::InvalidArgument("job state '" + s + "': expected queued, running, done, failed or cancelled");
}

namespace {

using sqlite::Database;
using sqlite::Statement;
using sqlite::Transaction;

// Bumped whenever the schema below changes; Open refuses a file written by a newer
// build rather than misreading it. (Migrations from older versions go in
// CreateOrCheckSchema when there is a version 2.)
constexpr int64_t kSchemaVersion = 1;

// Notes on the schema:
//  - kind and state are CHECKed in SQL too, so a bad value aborts the transaction
//    it is part of instead of being stored;
//  - e and the coefficients are NOT NULL because SQLite stores a NaN double as
//    NULL: a NaN E (a caller bug) fails loudly rather than turning into "unknown";
//  - evaluations carries the job's eval_key so LookupEvaluations finds sets
//    evaluated by any job with the same inputs and options through one index;
//  - coefficient values are compared as exact doubles: callers generate them
//    deterministically, so equal sets are bit-identical.
constexpr const char* kSchemaV1 = R"sql(
CREATE TABLE datasets(
  hash       TEXT PRIMARY KEY NOT NULL,
  name       TEXT NOT NULL,
  content    BLOB NOT NULL,
  created_at TEXT NOT NULL
);
CREATE TABLE jobs(
  id            INTEGER PRIMARY KEY AUTOINCREMENT,
  kind          TEXT NOT NULL CHECK (kind IN ('estimate', 'diagnose')),
  state         TEXT NOT NULL CHECK (state IN ('queued', 'running', 'done', 'failed', 'cancelled')),
  created_at    TEXT NOT NULL,
  updated_at    TEXT NOT NULL,
  dataset1_hash TEXT REFERENCES datasets(hash),
  dataset2_hash TEXT REFERENCES datasets(hash),
  dataset1_name TEXT NOT NULL,
  dataset2_name TEXT NOT NULL,
  options_json  TEXT NOT NULL,
  eval_key      TEXT NOT NULL,
  phase         TEXT NOT NULL,
  sets_done     INTEGER NOT NULL,
  sets_total    INTEGER NOT NULL,
  best_e        REAL NOT NULL,
  error         TEXT NOT NULL,
  result_json   TEXT NOT NULL
);
CREATE INDEX jobs_by_state ON jobs(state, id);
CREATE INDEX jobs_by_eval_key ON jobs(eval_key, state);
CREATE TABLE evaluations(
  job_id   INTEGER NOT NULL REFERENCES jobs(id),
  phase    INTEGER NOT NULL CHECK (phase >= 1),
  mu_n     REAL NOT NULL,
  mu_t     REAL NOT NULL,
  eta_n    REAL NOT NULL,
  eta_t    REAL NOT NULL,
  e        REAL NOT NULL,
  eval_key TEXT NOT NULL,
  PRIMARY KEY (job_id, phase, mu_n, mu_t, eta_n, eta_t)
) WITHOUT ROWID;
CREATE INDEX evaluations_by_key ON evaluations(eval_key, mu_n, mu_t, eta_n, eta_t);
CREATE TABLE survivors(
  job_id INTEGER NOT NULL REFERENCES jobs(id),
  phase  INTEGER NOT NULL CHECK (phase >= 1),
  rank   INTEGER NOT NULL,
  mu_n   REAL NOT NULL,
  mu_t   REAL NOT NULL,
  eta_n  REAL NOT NULL,
  eta_t  REAL NOT NULL,
  e      REAL NOT NULL,
  PRIMARY KEY (job_id, phase, rank)
) WITHOUT ROWID;
)sql";

constexpr const char* kJobColumns =
    "id, kind, state, created_at, updated_at, dataset1_hash, dataset2_hash, dataset1_name, dataset2_name, "
    "options_json, eval_key, phase, sets_done, sets_total, best_e, error, result_json";

std::string NowUtcIso8601() {
  const auto now = std::chrono::system_clock::now();
  const int64_t millis = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count();
  const std::time_t seconds = static_cast<std::time_t>(millis / 1000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char buf[80];  // wide enough for any int fields, so never truncated
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<int>(millis % 1000));
  return buf;
}

bool IsSha256Hex(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// A dataset is content-addressed, so a hash that does not match its content would
// poison every later job that names that hash: check it before storing.
Status ValidateDataset(const DatasetRecord& d, const std::string& what) {
  if (!IsSha256Hex(d.hash))
    return Status::InvalidArgument(what + " '" + d.name + "': hash '" + d.hash +
                                   "' is not 64 lower-case hex digits (SHA-256)");
  const std::string actual = Sha256Hex(d.content);
  if (actual != d.hash)
    return Status::InvalidArgument(what + " '" + d.name + "': hash " + d.hash + " does not match its content (" +
                                   actual + ")");
  return Status::Ok();
}

// An input slot with nothing in it (e.g. a job that takes one recording).
bool IsAbsent(const DatasetRecord& d) {
  return d.hash.empty() && d.name.empty() && d.content.empty();
}

void BindCoefficients(Statement& st, int first_index, const Coefficients& c) {
  st.BindDouble(first_index, c.mu_n);
  st.BindDouble(first_index + 1, c.mu_t);
  st.BindDouble(first_index + 2, c.eta_n);
  st.BindDouble(first_index + 3, c.eta_t);
}

// Reads columns (phase, mu_n, mu_t, eta_n, eta_t, e) starting at `first`.
EvaluationRecord ReadEvaluation(const Statement& st, int first) {
  EvaluationRecord r;
  r.phase = static_cast<int>(st.ColumnInt(first));
  r.set = {st.ColumnDouble(first + 1), st.ColumnDouble(first + 2), st.ColumnDouble(first + 3),
           st.ColumnDouble(first + 4)};
  r.e = st.ColumnDouble(first + 5);
  return r;
}

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

Status SqliteJobStore::Initialize(int busy_timeout_ms) {
  // busy_timeout first, so the PRAGMAs below wait for another process's lock.
  WORMDRAG_RETURN_IF_ERROR(db_.Exec("PRAGMA busy_timeout = " + std::to_string(busy_timeout_ms), "set busy_timeout"));
  auto journal = db_.QueryText("PRAGMA journal_mode = WAL", "set journal_mode=WAL");
  if (!journal.ok()) return journal.status();
  if (*journal != "wal")
    return Status::FailedPrecondition(db_.label() + ": cannot use WAL journal (got '" + *journal +
                                      "'); is the file on a network file system?");
  // FULL in WAL mode syncs the log at every commit: an acknowledged write survives power loss.
  WORMDRAG_RETURN_IF_ERROR(db_.Exec("PRAGMA synchronous = FULL", "set synchronous=FULL"));
  WORMDRAG_RETURN_IF_ERROR(db_.Exec("PRAGMA foreign_keys = ON", "enable foreign keys"));
  auto foreign_keys = db_.QueryInt("PRAGMA foreign_keys", "check foreign keys");
  if (!foreign_keys.ok()) return foreign_keys.status();
  if (*foreign_keys != 1) return Status::FailedPrecondition(db_.label() + ": SQLite built without foreign keys");
  return CreateOrCheckSchema();
}

Status SqliteJobStore::CreateOrCheckSchema() {
  // A write transaction, so two processes opening a new file at once do not both
  // try to create the tables.
  auto tx = Transaction::Begin(db_, Transaction::Mode::kWrite, "create schema");
  if (!tx.ok()) return tx.status();
  auto version = db_.QueryInt("PRAGMA user_version", "read schema version");
  if (!version.ok()) return version.status();
  if (*version == kSchemaVersion) return Status::Ok();  // the transaction only read; rolling back is fine
  if (*version > kSchemaVersion)
    return Status::FailedPrecondition(db_.label() + ": schema version " + std::to_string(*version) +
                                      " is newer than this build's (" + std::to_string(kSchemaVersion) +
                                      "); upgrade wormdrag");
  if (*version != 0)
    return Status::FailedPrecondition(db_.label() + ": schema version " + std::to_string(*version) +
                                      " has no migration to " + std::to_string(kSchemaVersion));
  WORMDRAG_RETURN_IF_ERROR(db_.Exec(kSchemaV1, "create schema"));
  WORMDRAG_RETURN_IF_ERROR(db_.Exec("PRAGMA user_version = " + std::to_string(kSchemaVersion), "set schema version"));
  return tx->Commit();
}

Status SqliteJobStore::InsertDataset(const DatasetRecord& d, const std::string& created_at) {
  // OR IGNORE: the row is keyed by its content's hash, so an existing row already
  // holds exactly these bytes.
  auto st = Statement::Prepare(
      db_, "INSERT OR IGNORE INTO datasets(hash, name, content, created_at) VALUES (?1, ?2, ?3, ?4)",
      "insert dataset " + d.hash);
  if (!st.ok()) return st.status();
  st->BindText(1, d.hash);
  st->BindText(2, d.name);
  st->BindBlob(3, d.content);
  st->BindText(4, created_at);
  return st->Run();
}

Status SqliteJobStore::PutDataset(const DatasetRecord& d) {
  WORMDRAG_RETURN_IF_ERROR(ValidateDataset(d, "dataset").Annotate(db_.label()));
  std::lock_guard<std::mutex> lock(mutex_);
  return InsertDataset(d, NowUtcIso8601());
}

Result<DatasetRecord> SqliteJobStore::GetDataset(const std::string& hash) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto st = Statement::Prepare(db_, "SELECT hash, name, content FROM datasets WHERE hash = ?1", "read dataset " + hash);
  if (!st.ok()) return st.status();
  st->BindText(1, hash);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::NotFound(db_.label() + ": dataset " + hash + ": not found");
  return DatasetRecord{st->ColumnText(0), st->ColumnText(1), st->ColumnBlob(2)};
}

Result<int64_t> SqliteJobStore::CreateJob(const JobRecord& job, const std::array<DatasetRecord, 2>& inputs) {
  // Everything that can be checked without the database is checked first.
  if (IsAbsent(inputs[0])) return Invalid("create job: inputs[0] is empty; a job needs at least one recording");
  for (int i = 0; i < 2; ++i) {
    const std::string slot = "create job: inputs[" + std::to_string(i) + "]";
    if (IsAbsent(inputs[i])) {
      if (!job.dataset_hashes[i].empty())
        return Invalid(slot + " is empty but the job names dataset " + job.dataset_hashes[i]);
      continue;
    }
    WORMDRAG_RETURN_IF_ERROR(ValidateDataset(inputs[i], slot).Annotate(db_.label()));
    if (!job.dataset_hashes[i].empty() && job.dataset_hashes[i] != inputs[i].hash)
      return Invalid(slot + " has hash " + inputs[i].hash + " but the job names dataset " + job.dataset_hashes[i]);
  }

  std::lock_guard<std::mutex> lock(mutex_);
  const std::string now = NowUtcIso8601();
  auto tx = Transaction::Begin(db_, Transaction::Mode::kWrite, "create job");
  if (!tx.ok()) return tx.status();
  for (const DatasetRecord& d : inputs) {
    if (!IsAbsent(d)) WORMDRAG_RETURN_IF_ERROR(InsertDataset(d, now));
  }
  auto st = Statement::Prepare(db_,
                               "INSERT INTO jobs(kind, state, created_at, updated_at, dataset1_hash, dataset2_hash, "
                               "dataset1_name, dataset2_name, options_json, eval_key, phase, sets_done, sets_total, "
                               "best_e, error, result_json) "
                               "VALUES (?1, ?2, ?3, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
                               "insert job");
  if (!st.ok()) return st.status();
  st->BindText(1, job.kind);
  st->BindText(2, JobStateName(JobState::kQueued));
  st->BindText(3, now);
  for (int i = 0; i < 2; ++i) {
    if (IsAbsent(inputs[i])) {
      st->BindNull(4 + i);
      st->BindText(6 + i, "");
    } else {
      st->BindText(4 + i, inputs[i].hash);
      // The job keeps the name it was submitted under; the dataset row keeps the
      // name of its first submission.
      st->BindText(6 + i, job.dataset_names[i].empty() ? inputs[i].name : job.dataset_names[i]);
    }
  }
  st->BindText(8, job.options_json);
  st->BindText(9, job.eval_key);
  st->BindText(10, job.phase);
  st->BindInt(11, job.sets_done);
  st->BindInt(12, job.sets_total);
  st->BindDouble(13, job.best_e);
  st->BindText(14, job.error);
  st->BindText(15, job.result_json);
  WORMDRAG_RETURN_IF_ERROR(st->Run());
  const int64_t id = db_.LastInsertRowId();
  WORMDRAG_RETURN_IF_ERROR(tx->Commit());
  return id;
}

Result<JobRecord> SqliteJobStore::ReadJob(const Statement& st) const {
  JobRecord job;
  job.id = st.ColumnInt(0);
  job.kind = st.ColumnText(1);
  const std::string state = st.ColumnText(2);
  auto parsed = ParseJobState(state);
  if (!parsed.ok())
    return Status::Internal(db_.label() + ": job " + std::to_string(job.id) + ": " + parsed.status().message());
  job.state = *parsed;
  job.created_at = st.ColumnText(3);
  job.updated_at = st.ColumnText(4);
  job.dataset_hashes = {st.ColumnText(5), st.ColumnText(6)};
  job.dataset_names = {st.ColumnText(7), st.ColumnText(8)};
  job.options_json = st.ColumnText(9);
  job.eval_key = st.ColumnText(10);
  job.phase = st.ColumnText(11);
  job.sets_done = st.ColumnInt(12);
  job.sets_total = st.ColumnInt(13);
  job.best_e = st.ColumnDouble(14);
  job.error = st.ColumnText(15);
  job.result_json = st.ColumnText(16);
  return job;
}

Result<JobRecord> SqliteJobStore::GetJob(int64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto st = Statement::Prepare(db_, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?1",
                               "read job " + std::to_string(id));
  if (!st.ok()) return st.status();
  st->BindInt(1, id);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return NotFoundJob(id);
  return ReadJob(*st);
}

Result<std::vector<JobRecord>> SqliteJobStore::QueryJobs(const std::string& sql,
                                                         const std::function<void(Statement&)>& bind) {
  auto st = Statement::Prepare(db_, sql, "list jobs");
  if (!st.ok()) return st.status();
  bind(*st);
  std::vector<JobRecord> jobs;
  while (true) {
    auto row = st->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    auto job = ReadJob(*st);
    if (!job.ok()) return job.status();
    jobs.push_back(std::move(*job));
  }
  return jobs;
}

Result<std::vector<JobRecord>> SqliteJobStore::ListJobs(int limit) {
  if (limit < 0) return Invalid("list jobs: limit must be >= 0, got " + std::to_string(limit));
  std::lock_guard<std::mutex> lock(mutex_);
  // Ids grow with every insert (AUTOINCREMENT never reuses one), so id order is
  // creation order even if the wall clock jumps back.
  return QueryJobs(std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ?1",
                   [&](Statement& st) { st.BindInt(1, limit == 0 ? -1 : limit); });  // -1: no limit
}

Result<std::vector<JobRecord>> SqliteJobStore::JobsInState(JobState s) {
  std::lock_guard<std::mutex> lock(mutex_);
  return QueryJobs(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE state = ?1 ORDER BY id ASC",
                   [&](Statement& st) { st.BindText(1, JobStateName(s)); });
}

Result<std::optional<int64_t>> SqliteJobStore::FindDoneJob(const std::string& eval_key,
                                                           const std::string& options_json) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto st = Statement::Prepare(
      db_, "SELECT id FROM jobs WHERE eval_key = ?1 AND options_json = ?2 AND state = 'done' ORDER BY id DESC LIMIT 1",
      "find done job");
  if (!st.ok()) return st.status();
  st->BindText(1, eval_key);
  st->BindText(2, options_json);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return std::optional<int64_t>();
  return std::optional<int64_t>(st->ColumnInt(0));
}

Status SqliteJobStore::UpdateJob(int64_t id, const std::string& sql, const std::string& what,
                                 const std::function<void(Statement&)>& bind) {
  // A single UPDATE is its own transaction in SQLite; no explicit one is needed.
  auto st = Statement::Prepare(db_, sql, what + " of job " + std::to_string(id));
  if (!st.ok()) return st.status();
  bind(*st);
  WORMDRAG_RETURN_IF_ERROR(st->Run());
  if (db_.Changes() == 0) return NotFoundJob(id);
  return Status::Ok();
}

Status SqliteJobStore::SetState(int64_t id, JobState s, const std::string& error) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The error is replaced, not kept: a job that is re-run after failing should
  // not show the old reason.
  return UpdateJob(id, "UPDATE jobs SET state = ?1, error = ?2, updated_at = ?3 WHERE id = ?4", "set state",
                   [&](Statement& st) {
                     st.BindText(1, JobStateName(s));
                     st.BindText(2, error);
                     st.BindText(3, NowUtcIso8601());
                     st.BindInt(4, id);
                   });
}

Status SqliteJobStore::SetProgress(int64_t id, const std::string& phase, int64_t done, int64_t total, double best_e) {
  if (done < 0 || total < 0)
    return Invalid("set progress of job " + std::to_string(id) + ": negative count (" + std::to_string(done) + " of " +
                   std::to_string(total) + ")");
  std::lock_guard<std::mutex> lock(mutex_);
  return UpdateJob(id,
                   "UPDATE jobs SET phase = ?1, sets_done = ?2, sets_total = ?3, best_e = ?4, updated_at = ?5 "
                   "WHERE id = ?6",
                   "set progress", [&](Statement& st) {
                     st.BindText(1, phase);
                     st.BindInt(2, done);
                     st.BindInt(3, total);
                     st.BindDouble(4, best_e);
                     st.BindText(5, NowUtcIso8601());
                     st.BindInt(6, id);
                   });
}

Status SqliteJobStore::SetResult(int64_t id, const std::string& result_json) {
  std::lock_guard<std::mutex> lock(mutex_);
  return UpdateJob(id, "UPDATE jobs SET result_json = ?1, state = 'done', error = '', updated_at = ?2 WHERE id = ?3",
                   "set result", [&](Statement& st) {
                     st.BindText(1, result_json);
                     st.BindText(2, NowUtcIso8601());
                     st.BindInt(3, id);
                   });
}

Result<std::string> SqliteJobStore::JobEvalKey(int64_t id) {
  auto st = Statement::Prepare(db_, "SELECT eval_key FROM jobs WHERE id = ?1", "read job " + std::to_string(id));
  if (!st.ok()) return st.status();
  st->BindInt(1, id);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return NotFoundJob(id);
  return st->ColumnText(0);
}

Status SqliteJobStore::PutEvaluations(int64_t job, const std::vector<EvaluationRecord>& batch) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto tx = Transaction::Begin(db_, Transaction::Mode::kWrite, "store evaluations");
  if (!tx.ok()) return tx.status();
  auto eval_key = JobEvalKey(job);
  if (!eval_key.ok()) return eval_key.status();
  // ON CONFLICT(primary key) DO NOTHING rather than INSERT OR IGNORE: both keep the
  // first value of a set already stored, but OR IGNORE would also silently skip a
  // row violating NOT NULL or CHECK (a NaN E, phase 0), which must fail instead.
  auto st = Statement::Prepare(db_,
                               "INSERT INTO evaluations(job_id, phase, mu_n, mu_t, eta_n, eta_t, e, eval_key) "
                               "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) "
                               "ON CONFLICT(job_id, phase, mu_n, mu_t, eta_n, eta_t) DO NOTHING",
                               "insert evaluation");
  if (!st.ok()) return st.status();
  for (size_t i = 0; i < batch.size(); ++i) {
    const EvaluationRecord& r = batch[i];
    st->BindInt(1, job);
    st->BindInt(2, r.phase);
    BindCoefficients(*st, 3, r.set);
    st->BindDouble(7, r.e);
    st->BindText(8, *eval_key);
    Status s = st->Run();
    if (!s.ok())
      return s.Annotate("job " + std::to_string(job) + ": evaluation " + std::to_string(i) + " of " +
                        std::to_string(batch.size()) + " (phase " + std::to_string(r.phase) + ", set " +
                        r.set.ToString() + ", E " + std::to_string(r.e) + "); nothing of the batch stored");
    st->Reset();
  }
  return tx->Commit();
}

Status SqliteJobStore::LookupEvaluations(const std::string& eval_key, const std::vector<Coefficients>& sets,
                                         std::vector<std::optional<double>>* result) {
  if (result == nullptr) return Invalid("lookup evaluations: result is null");
  // An empty key would match every job created without one: never a valid reuse.
  if (eval_key.empty()) return Invalid("lookup evaluations: empty eval_key");
  result->assign(sets.size(), std::nullopt);
  std::lock_guard<std::mutex> lock(mutex_);
  // One read transaction: one consistent snapshot and one lock for the whole list.
  auto tx = Transaction::Begin(db_, Transaction::Mode::kRead, "lookup evaluations");
  if (!tx.ok()) return tx.status();
  // If two jobs stored different E for the same set (they should not: same key,
  // deterministic simulation), the oldest job's value wins, deterministically.
  // Failed and cancelled jobs are never a source: a job fails because something went
  // wrong while it ran (a quarantined task, a worker caught lying by a spot-check, a
  // bug), and a cancelled job's values are not vouched for by a finished run either.
  // A job resumed after a coordinator restart is still running and reuses its own.
  auto st = Statement::Prepare(db_,
                               "SELECT ev.e FROM evaluations ev JOIN jobs j ON j.id = ev.job_id "
                               "WHERE ev.eval_key = ?1 AND ev.mu_n = ?2 AND ev.mu_t = ?3 AND ev.eta_n = ?4 "
                               "AND ev.eta_t = ?5 AND j.state NOT IN ('failed', 'cancelled') "
                               "ORDER BY ev.job_id, ev.phase LIMIT 1",
                               "lookup evaluation");
  if (!st.ok()) return st.status();
  for (size_t i = 0; i < sets.size(); ++i) {
    st->BindText(1, eval_key);
    BindCoefficients(*st, 2, sets[i]);
    auto row = st->Step();
    if (!row.ok()) return row.status();
    if (*row) (*result)[i] = st->ColumnDouble(0);
    st->Reset();
  }
  return tx->Commit();
}

Result<std::vector<EvaluationRecord>> SqliteJobStore::Evaluations(int64_t job, int phase, int64_t limit) {
  if (phase < 0 || limit < 0)
    return Invalid("evaluations of job " + std::to_string(job) + ": phase and limit must be >= 0");
  std::lock_guard<std::mutex> lock(mutex_);
  auto tx = Transaction::Begin(db_, Transaction::Mode::kRead, "read evaluations");
  if (!tx.ok()) return tx.status();
  auto exists = JobEvalKey(job);  // NOT_FOUND for an unknown job, not an empty list
  if (!exists.ok()) return exists.status();
  // Ties in E are broken by the set, so the order is the same on every call.
  auto st = Statement::Prepare(db_,
                               "SELECT phase, mu_n, mu_t, eta_n, eta_t, e FROM evaluations "
                               "WHERE job_id = ?1 AND (?2 = 0 OR phase = ?2) "
                               "ORDER BY e, phase, mu_n, mu_t, eta_n, eta_t LIMIT ?3",
                               "read evaluations of job " + std::to_string(job));
  if (!st.ok()) return st.status();
  st->BindInt(1, job);
  st->BindInt(2, phase);
  st->BindInt(3, limit == 0 ? -1 : limit);
  std::vector<EvaluationRecord> records;
  while (true) {
    auto row = st->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    records.push_back(ReadEvaluation(*st, 0));
  }
  return records;
}

Result<std::map<JobState, int64_t>> SqliteJobStore::CountJobsByState() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<JobState, int64_t> counts;
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kFailed, JobState::kCancelled})
    counts[s] = 0;
  auto st = Statement::Prepare(db_, "SELECT state, count(*) FROM jobs GROUP BY state", "count jobs by state");
  if (!st.ok()) return st.status();
  for (;;) {
    auto row = st->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    auto s = ParseJobState(st->ColumnText(0));
    if (!s.ok()) return s.status();
    counts[*s] = st->ColumnInt(1);
  }
  return counts;
}

Result<int64_t> SqliteJobStore::CountEvaluations(int64_t job, int phase) {
  if (phase < 0) return Invalid("count evaluations of job " + std::to_string(job) + ": phase must be >= 0");
  std::lock_guard<std::mutex> lock(mutex_);
  auto tx = Transaction::Begin(db_, Transaction::Mode::kRead, "count evaluations");
  if (!tx.ok()) return tx.status();
  auto exists = JobEvalKey(job);
  if (!exists.ok()) return exists.status();
  auto st = Statement::Prepare(db_, "SELECT count(*) FROM evaluations WHERE job_id = ?1 AND (?2 = 0 OR phase = ?2)",
                               "count evaluations of job " + std::to_string(job));
  if (!st.ok()) return st.status();
  st->BindInt(1, job);
  st->BindInt(2, phase);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  return st->ColumnInt(0);
}

Status SqliteJobStore::PutSurvivors(int64_t job, int phase, const std::vector<EvaluationRecord>& ranked) {
  if (phase < 1) return Invalid("survivors of job " + std::to_string(job) + ": phase must be >= 1");
  std::lock_guard<std::mutex> lock(mutex_);
  // Delete and insert in one transaction: a failure keeps the previous survivors.
  auto tx = Transaction::Begin(db_, Transaction::Mode::kWrite, "store survivors");
  if (!tx.ok()) return tx.status();
  auto exists = JobEvalKey(job);
  if (!exists.ok()) return exists.status();
  auto del = Statement::Prepare(db_, "DELETE FROM survivors WHERE job_id = ?1 AND phase = ?2",
                                "delete survivors of job " + std::to_string(job));
  if (!del.ok()) return del.status();
  del->BindInt(1, job);
  del->BindInt(2, phase);
  WORMDRAG_RETURN_IF_ERROR(del->Run());
  auto st = Statement::Prepare(db_,
                               "INSERT INTO survivors(job_id, phase, rank, mu_n, mu_t, eta_n, eta_t, e) "
                               "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
                               "insert survivor of job " + std::to_string(job));
  if (!st.ok()) return st.status();
  for (size_t i = 0; i < ranked.size(); ++i) {
    st->BindInt(1, job);
    st->BindInt(2, phase);
    st->BindInt(3, static_cast<int64_t>(i));
    BindCoefficients(*st, 4, ranked[i].set);
    st->BindDouble(8, ranked[i].e);
    Status s = st->Run();
    if (!s.ok())
      return s.Annotate("survivor " + std::to_string(i) + " of " + std::to_string(ranked.size()) + " (set " +
                        ranked[i].set.ToString() + "); previous survivors kept");
    st->Reset();
  }
  return tx->Commit();
}

Result<std::vector<EvaluationRecord>> SqliteJobStore::Survivors(int64_t job, int phase) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto tx = Transaction::Begin(db_, Transaction::Mode::kRead, "read survivors");
  if (!tx.ok()) return tx.status();
  auto exists = JobEvalKey(job);
  if (!exists.ok()) return exists.status();
  auto st = Statement::Prepare(db_,
                               "SELECT phase, mu_n, mu_t, eta_n, eta_t, e FROM survivors "
                               "WHERE job_id = ?1 AND phase = ?2 ORDER BY rank",
                               "read survivors of job " + std::to_string(job));
  if (!st.ok()) return st.status();
  st->BindInt(1, job);
  st->BindInt(2, phase);
  std::vector<EvaluationRecord> records;
  while (true) {
    auto row = st->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    records.push_back(ReadEvaluation(*st, 0));
  }
  return records;
}

}  // namespace

Result<std::unique_ptr<JobStore>> JobStore::Open(const std::string& path, int busy_timeout_ms) {
  auto db = Database::Open(path);
  if (!db.ok()) return db.status();
  auto store = std::make_unique<SqliteJobStore>(std::move(*db));
  WORMDRAG_RETURN_IF_ERROR(store->Initialize(busy_timeout_ms));
  return std::unique_ptr<JobStore>(std::move(store));
}

}  // namespace wormdrag
