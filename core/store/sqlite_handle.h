// RAII wrappers around the SQLite C API, private to core/store (never included
// from a public header, so sqlite3.h stays out of everyone else's build).
//
// Every failure becomes a Status whose message starts with the database's label
// (its path), so "jobs.db: insert evaluation: UNIQUE constraint failed" tells the
// reader which file and which operation failed.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/common/status.h"

struct sqlite3;
struct sqlite3_stmt;

namespace wormdrag::sqlite {

// Maps an SQLite result code onto the project's Status codes: constraint
// violations are the caller's bad input, BUSY/LOCKED are transient (another
// process holds the lock past busy_timeout), a full disk is exhausted resources.
Status StatusFromCode(int rc, const std::string& message);

// One connection. Move-only; closes on destruction.
class Database {
 public:
  // Opens (creating if needed) `path`. The label in messages is the path.
  static Result<Database> Open(const std::string& path);

  Database(Database&& other) noexcept;
  Database& operator=(Database&& other) noexcept;
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;
  ~Database();

  // Runs SQL that returns no rows we need (PRAGMAs that set, DDL, BEGIN/COMMIT).
  // `what` names the operation in the error message.
  Status Exec(const std::string& sql, const std::string& what);
  // Runs SQL returning one text value (e.g. "PRAGMA journal_mode=WAL" -> "wal").
  Result<std::string> QueryText(const std::string& sql, const std::string& what);
  Result<int64_t> QueryInt(const std::string& sql, const std::string& what);

  // A Status for the connection's last error, prefixed "<label>: <what>: ".
  Status LastError(int rc, const std::string& what) const;

  sqlite3* handle() const { return db_; }
  const std::string& label() const { return label_; }
  int64_t Changes() const;  // rows changed by the last INSERT/UPDATE/DELETE
  int64_t LastInsertRowId() const;
  bool InTransaction() const;

 private:
  Database(sqlite3* db, std::string label) : db_(db), label_(std::move(label)) {}
  sqlite3* db_ = nullptr;
  std::string label_;
};

// One prepared statement. Move-only; finalizes on destruction.
//
// Bind* calls do not return a Status: the first bind failure is remembered and
// returned by the next Step/Run. That keeps call sites to one line per column
// without losing any error.
class Statement {
 public:
  static Result<Statement> Prepare(Database& db, const std::string& sql, const std::string& what);

  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  // Parameters are 1-based, as in SQLite.
  void BindInt(int index, int64_t value);
  void BindDouble(int index, double value);  // NaN would be stored as NULL: callers avoid it
  void BindText(int index, std::string_view value);
  void BindBlob(int index, std::string_view bytes);
  void BindNull(int index);

  // One step: true when a row is available, false when the statement is done.
  Result<bool> Step();
  // Steps a statement that returns no rows to completion.
  Status Run();
  // Makes the statement ready to be bound and run again (bindings cleared).
  void Reset();

  // Columns are 0-based, as in SQLite.
  bool ColumnIsNull(int index) const;
  int64_t ColumnInt(int index) const;
  double ColumnDouble(int index) const;     // NULL reads back as NaN, never as 0
  std::string ColumnText(int index) const;  // NULL reads back as ""
  std::string ColumnBlob(int index) const;

 private:
  Statement(Database* db, sqlite3_stmt* stmt, std::string what) : db_(db), stmt_(stmt), what_(std::move(what)) {}
  void NoteBindError(int rc, int index);
  Database* db_ = nullptr;
  sqlite3_stmt* stmt_ = nullptr;
  std::string what_;
  Status bind_error_;
};

// A transaction that rolls back unless Commit() succeeded, so an early return on
// any error leaves nothing half-stored.
class Transaction {
 public:
  // kWrite takes the write lock at BEGIN (BEGIN IMMEDIATE): a deferred transaction
  // that reads first and writes later can fail with SQLITE_BUSY mid-way without
  // busy_timeout helping, an immediate one waits for the lock up front.
  enum class Mode { kRead, kWrite };
  static Result<Transaction> Begin(Database& db, Mode mode, const std::string& what);

  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();

  Status Commit();

 private:
  Transaction(Database* db, std::string what) : db_(db), what_(std::move(what)) {}
  Database* db_ = nullptr;  // null once committed or moved from
  std::string what_;
};

}  // namespace wormdrag::sqlite
