// The job store's file: its schema and version, the connection settings, and
// JobStore::Open. The rows are read and written in job_store.cc and
// job_store_evaluations.cc.
#include "core/store/job_store.h"

#include <memory>
#include <string>
#include <utility>

#include "core/store/sqlite_job_store.h"

namespace wormdrag {

namespace store_internal {
namespace {

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

}  // namespace

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

}  // namespace store_internal

Result<std::unique_ptr<JobStore>> JobStore::Open(const std::string& path, int busy_timeout_ms) {
  auto db = sqlite::Database::Open(path);
  if (!db.ok()) return db.status();
  auto store = std::make_unique<store_internal::SqliteJobStore>(std::move(*db));
  WORMDRAG_RETURN_IF_ERROR(store->Initialize(busy_timeout_ms));
  return std::unique_ptr<JobStore>(std::move(store));
}

}  // namespace wormdrag
