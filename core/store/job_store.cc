// The SQLite job store's datasets and jobs. The schema and JobStore::Open are in
// job_store_schema.cc; the evaluated sets and survivors in job_store_evaluations.cc.
#include "core/store/job_store.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <mutex>
#include <utility>

#include "core/store/sqlite_job_store.h"

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

namespace store_internal {
namespace {

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

}  // namespace

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

}  // namespace store_internal
}  // namespace wormdrag
