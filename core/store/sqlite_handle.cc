#include "core/store/sqlite_handle.h"

#include <sqlite3.h>

#include <cmath>
#include <limits>
#include <utility>

namespace wormdrag::sqlite {

Status StatusFromCode(int rc, const std::string& message) {
  switch (rc & 0xff) {  // the primary code of an extended result code
    case SQLITE_CONSTRAINT:
    case SQLITE_MISMATCH:
    case SQLITE_RANGE:
    case SQLITE_TOOBIG:
      return Status::InvalidArgument(message);
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Status::Unavailable(message);
    case SQLITE_FULL:
    case SQLITE_NOMEM:
      return Status::ResourceExhausted(message);
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
    case SQLITE_READONLY:
    case SQLITE_NOTADB:
    case SQLITE_AUTH:
      return Status::FailedPrecondition(message);
    default:
      return Status::Internal(message);
  }
}

// ---------------------------------------------------------------- Database

Result<Database> Database::Open(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
  if (rc != SQLITE_OK) {
    // sqlite3_open_v2 returns a handle even on failure (for the message); it must be closed.
    std::string message = path + ": cannot open: " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
    sqlite3_close(db);
    return StatusFromCode(rc, message);
  }
  sqlite3_extended_result_codes(db, 1);
  return Database(db, path);
}

Database::Database(Database&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)), label_(std::move(other.label_)) {}

Database& Database::operator=(Database&& other) noexcept {
  if (this != &other) {
    sqlite3_close(db_);
    db_ = std::exchange(other.db_, nullptr);
    label_ = std::move(other.label_);
  }
  return *this;
}

Database::~Database() {
  // All statements are finalized before the store drops its Database (they are
  // locals of the store's methods), so close cannot fail with SQLITE_BUSY here.
  sqlite3_close(db_);
}

Status Database::LastError(int rc, const std::string& what) const {
  return StatusFromCode(rc, label_ + ": " + what + ": " + sqlite3_errmsg(db_));
}

Status Database::Exec(const std::string& sql, const std::string& what) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
  if (rc == SQLITE_OK) return Status::Ok();
  std::string message = label_ + ": " + what + ": " + (error ? error : sqlite3_errstr(rc));
  sqlite3_free(error);
  return StatusFromCode(rc, message);
}

Result<std::string> Database::QueryText(const std::string& sql, const std::string& what) {
  auto st = Statement::Prepare(*this, sql, what);
  if (!st.ok()) return st.status();
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::Internal(label_ + ": " + what + ": no row returned");
  return st->ColumnText(0);
}

Result<int64_t> Database::QueryInt(const std::string& sql, const std::string& what) {
  auto st = Statement::Prepare(*this, sql, what);
  if (!st.ok()) return st.status();
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return Status::Internal(label_ + ": " + what + ": no row returned");
  return st->ColumnInt(0);
}

int64_t Database::Changes() const {
  return sqlite3_changes64(db_);
}
int64_t Database::LastInsertRowId() const {
  return sqlite3_last_insert_rowid(db_);
}
bool Database::InTransaction() const {
  return sqlite3_get_autocommit(db_) == 0;
}

// ---------------------------------------------------------------- Statement

Result<Statement> Statement::Prepare(Database& db, const std::string& sql, const std::string& what) {
  sqlite3_stmt* stmt = nullptr;
  const int rc = sqlite3_prepare_v2(db.handle(), sql.c_str(), static_cast<int>(sql.size() + 1), &stmt, nullptr);
  if (rc != SQLITE_OK) {
    sqlite3_finalize(stmt);
    return db.LastError(rc, what + ": prepare");
  }
  return Statement(&db, stmt, what);
}

Statement::Statement(Statement&& other) noexcept
    : db_(other.db_),
      stmt_(std::exchange(other.stmt_, nullptr)),
      what_(std::move(other.what_)),
      bind_error_(std::move(other.bind_error_)) {}

Statement& Statement::operator=(Statement&& other) noexcept {
  if (this != &other) {
    sqlite3_finalize(stmt_);
    db_ = other.db_;
    stmt_ = std::exchange(other.stmt_, nullptr);
    what_ = std::move(other.what_);
    bind_error_ = std::move(other.bind_error_);
  }
  return *this;
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

void Statement::NoteBindError(int rc, int index) {
  if (rc == SQLITE_OK || !bind_error_.ok()) return;
  bind_error_ = db_->LastError(rc, what_ + ": bind parameter " + std::to_string(index));
}

void Statement::BindInt(int index, int64_t value) {
  NoteBindError(sqlite3_bind_int64(stmt_, index, value), index);
}

void Statement::BindDouble(int index, double value) {
  NoteBindError(sqlite3_bind_double(stmt_, index, value), index);
}

void Statement::BindText(int index, std::string_view value) {
  // The pointer of an empty string_view may be null, which SQLite would bind as
  // NULL rather than ''; point at a real empty string instead.
  const char* data = value.empty() ? "" : value.data();
  NoteBindError(sqlite3_bind_text64(stmt_, index, data, value.size(), SQLITE_TRANSIENT, SQLITE_UTF8), index);
}

void Statement::BindBlob(int index, std::string_view bytes) {
  // Same reason as in BindText: a zero-length blob, not NULL, for empty content.
  if (bytes.empty()) {
    NoteBindError(sqlite3_bind_zeroblob(stmt_, index, 0), index);
    return;
  }
  NoteBindError(sqlite3_bind_blob64(stmt_, index, bytes.data(), bytes.size(), SQLITE_TRANSIENT), index);
}

void Statement::BindNull(int index) {
  NoteBindError(sqlite3_bind_null(stmt_, index), index);
}

Result<bool> Statement::Step() {
  if (!bind_error_.ok()) return bind_error_;
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return db_->LastError(rc, what_);
}

Status Statement::Run() {
  auto row = Step();
  if (!row.ok()) return row.status();
  if (*row) return Status::Internal(db_->label() + ": " + what_ + ": unexpected row");
  return Status::Ok();
}

void Statement::Reset() {
  // sqlite3_reset repeats the last step's error code; that error was already
  // reported by Step, so it is not an error of the reset.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
  bind_error_ = Status::Ok();
}

bool Statement::ColumnIsNull(int index) const {
  return sqlite3_column_type(stmt_, index) == SQLITE_NULL;
}

int64_t Statement::ColumnInt(int index) const {
  return sqlite3_column_int64(stmt_, index);
}

double Statement::ColumnDouble(int index) const {
  if (ColumnIsNull(index)) return std::numeric_limits<double>::quiet_NaN();
  return sqlite3_column_double(stmt_, index);
}

std::string Statement::ColumnText(int index) const {
  const unsigned char* text = sqlite3_column_text(stmt_, index);
  if (!text) return std::string();
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(sqlite3_column_bytes(stmt_, index)));
}

std::string Statement::ColumnBlob(int index) const {
  const void* blob = sqlite3_column_blob(stmt_, index);
  if (!blob) return std::string();  // NULL or a zero-length blob
  return std::string(static_cast<const char*>(blob), static_cast<size_t>(sqlite3_column_bytes(stmt_, index)));
}

// ---------------------------------------------------------------- Transaction

Result<Transaction> Transaction::Begin(Database& db, Mode mode, const std::string& what) {
  Status s = db.Exec(mode == Mode::kWrite ? "BEGIN IMMEDIATE" : "BEGIN DEFERRED", what + ": begin transaction");
  if (!s.ok()) return s;
  return Transaction(&db, what);
}

Transaction::Transaction(Transaction&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)), what_(std::move(other.what_)) {}

Transaction::~Transaction() {
  // SQLite may already have rolled back by itself (e.g. after SQLITE_FULL); a
  // second ROLLBACK would only fail, so check first.
  if (db_ && db_->InTransaction()) db_->Exec("ROLLBACK", what_ + ": rollback");
}

Status Transaction::Commit() {
  if (!db_) return Status::Internal("transaction: commit after commit");
  Status s = db_->Exec("COMMIT", what_ + ": commit");
  if (s.ok()) db_ = nullptr;  // on failure the destructor rolls back
  return s;
}

}  // namespace wormdrag::sqlite
