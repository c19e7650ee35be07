#include "server/task_store.h"

#include <chrono>
#include <optional>

#include "core/store/sqlite_handle.h"

namespace wormdrag::server {

using sqlite::Database;
using sqlite::Statement;
using sqlite::Transaction;

struct TaskStore::Impl {
  Database write_db;  // used by the writer thread only
  Database read_db;   // lookups (WAL: readers never block the writer)
  std::mutex read_mu;
  std::optional<Statement> insert;  // the writer's, prepared once
};

struct TaskStore::Pending {
  std::string task_id;
  int64_t job;
  const std::string* blob;
  bool done = false;
  Status status;
};

namespace {

Status Configure(Database& db, int busy_timeout_ms) {
  WORMDRAG_RETURN_IF_ERROR(db.Exec("PRAGMA busy_timeout = " + std::to_string(busy_timeout_ms), "set busy_timeout"));
  auto journal = db.QueryText("PRAGMA journal_mode = WAL", "set journal_mode=WAL");
  if (!journal.ok()) return journal.status();
  WORMDRAG_RETURN_IF_ERROR(db.Exec("PRAGMA synchronous = FULL", "set synchronous=FULL"));
  return Status::Ok();
}

}  // namespace

Result<std::unique_ptr<TaskStore>> TaskStore::Open(const std::string& path, StorageHealth* health,
                                                   int busy_timeout_ms) {
  auto w = Database::Open(path);
  if (!w.ok()) return w.status();
  WORMDRAG_RETURN_IF_ERROR(Configure(*w, busy_timeout_ms));
  WORMDRAG_RETURN_IF_ERROR(
      w->Exec("CREATE TABLE IF NOT EXISTS task_results("
              "  task_id TEXT PRIMARY KEY NOT NULL,"
              "  job_id  INTEGER NOT NULL,"
              "  result  BLOB NOT NULL) WITHOUT ROWID;"
              "CREATE INDEX IF NOT EXISTS task_results_by_job ON task_results(job_id);"
              "CREATE TABLE IF NOT EXISTS task_attempts("
              "  task_id    TEXT PRIMARY KEY NOT NULL,"
              "  job_id     INTEGER NOT NULL,"
              "  failures   INTEGER NOT NULL,"
              "  lost       INTEGER NOT NULL,"
              "  workers    TEXT NOT NULL,"
              "  last_error TEXT NOT NULL) WITHOUT ROWID;"
              "CREATE INDEX IF NOT EXISTS task_attempts_by_job ON task_attempts(job_id);",
              "create task_results"));
  auto r = Database::Open(path);
  if (!r.ok()) return r.status();
  WORMDRAG_RETURN_IF_ERROR(Configure(*r, busy_timeout_ms));
  auto impl = std::unique_ptr<Impl>(new Impl{std::move(*w), std::move(*r), {}, {}});
  return std::unique_ptr<TaskStore>(new TaskStore(std::move(impl), health));
}

TaskStore::TaskStore(std::unique_ptr<Impl> impl, StorageHealth* health) : impl_(std::move(impl)), health_(health) {
  writer_ = std::thread([this] { WriterLoop(); });
}

TaskStore::~TaskStore() {
  Close();
}

void TaskStore::Close() {
  {
    std::lock_guard<std::mutex> l(mu_);
    closing_ = true;
  }
  cv_.notify_all();
  if (writer_.joinable()) writer_.join();
}

Status TaskStore::Put(const std::string& task_id, int64_t job, const std::string& blob) {
  Pending p{task_id, job, &blob, false, Status::Ok()};
  // While the disk is full the batch in hand is retried; a new result is refused
  // rather than queued unseen, and its worker retries it.
  if (health_ && health_->full())
    return Status::Unavailable("the coordinator's disk is full; retry later (" + health_->full_reason() + ")");
  std::unique_lock<std::mutex> l(mu_);
  if (closing_) return Status::Unavailable("coordinator is shutting down");
  queue_.push_back(&p);
  cv_.notify_all();
  cv_.wait(l, [&] { return p.done; });
  return p.status;
}

Status TaskStore::CommitBatch(const std::deque<Pending*>& batch) {
  Database& db = impl_->write_db;
  if (!impl_->insert) {
    auto stmt = Statement::Prepare(db, "INSERT OR IGNORE INTO task_results(task_id, job_id, result) VALUES(?,?,?)",
                                   "insert task result");
    if (!stmt.ok()) return stmt.status();
    impl_->insert.emplace(std::move(*stmt));
  }
  Statement& stmt = *impl_->insert;
  auto tx = Transaction::Begin(db, Transaction::Mode::kWrite, "store task results");
  if (!tx.ok()) return tx.status();
  for (Pending* p : batch) {
    stmt.Reset();
    stmt.BindText(1, p->task_id);
    stmt.BindInt(2, p->job);
    stmt.BindBlob(3, *p->blob);
    WORMDRAG_RETURN_IF_ERROR(stmt.Run());
  }
  stmt.Reset();
  return tx->Commit();
}

void TaskStore::WriterLoop() {
  std::unique_lock<std::mutex> l(mu_);
  for (;;) {
    cv_.wait(l, [&] { return closing_ || !queue_.empty(); });
    if (queue_.empty() && closing_) return;
    std::deque<Pending*> batch;
    batch.swap(queue_);
    l.unlock();
    // One transaction for everything that arrived while the previous one committed;
    // the whole transaction is redone when a busy lock or a full disk stopped it.
    const auto t0 = std::chrono::steady_clock::now();
    const Status st = health_ ? health_->Retry(
                                    "store task results", [&] { return CommitBatch(batch); },
                                    StorageHealth::WhenFull::kWait,
                                    [&] {
                                      std::lock_guard<std::mutex> g(mu_);
                                      return closing_;
                                    })
                              : CommitBatch(batch);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    l.lock();
    ++commits_;
    if (st.ok()) {
      ++stats_.count;
      stats_.results += static_cast<int64_t>(batch.size());
      stats_.seconds_sum += seconds;
      for (size_t i = 0; i < CommitStats::kBounds.size(); ++i)
        if (seconds <= CommitStats::kBounds[i]) ++stats_.le[i];
    }
    for (Pending* p : batch) {
      p->status = st;
      p->done = true;
    }
    cv_.notify_all();
  }
}

CommitStats TaskStore::commit_stats() {
  std::lock_guard<std::mutex> l(mu_);
  return stats_;
}

Result<std::optional<std::string>> TaskStore::Get(const std::string& task_id) {
  std::lock_guard<std::mutex> l(impl_->read_mu);
  auto st = Statement::Prepare(impl_->read_db, "SELECT result FROM task_results WHERE task_id = ?", "get task result");
  if (!st.ok()) return st.status();
  st->BindText(1, task_id);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return std::optional<std::string>();
  return std::optional<std::string>(st->ColumnBlob(0));
}

Status TaskStore::PutAttempts(const std::string& task_id, int64_t job, const TaskAttempts& a) {
  // Rare and small: through the read connection, serialised by SQLite's write lock.
  std::lock_guard<std::mutex> l(impl_->read_mu);
  auto st = Statement::Prepare(impl_->read_db,
                               "INSERT OR REPLACE INTO task_attempts(task_id, job_id, failures, lost, workers, "
                               "last_error) VALUES(?,?,?,?,?,?)",
                               "store task attempts");
  if (!st.ok()) return st.status();
  st->BindText(1, task_id);
  st->BindInt(2, job);
  st->BindInt(3, a.failures);
  st->BindInt(4, a.lost);
  st->BindText(5, a.workers);
  st->BindText(6, a.last_error);
  return st->Run();
}

Result<std::optional<TaskAttempts>> TaskStore::GetAttempts(const std::string& task_id) {
  std::lock_guard<std::mutex> l(impl_->read_mu);
  auto st = Statement::Prepare(impl_->read_db,
                               "SELECT failures, lost, workers, last_error FROM task_attempts WHERE task_id = ?",
                               "get task attempts");
  if (!st.ok()) return st.status();
  st->BindText(1, task_id);
  auto row = st->Step();
  if (!row.ok()) return row.status();
  if (!*row) return std::optional<TaskAttempts>();
  TaskAttempts a;
  a.failures = static_cast<int>(st->ColumnInt(0));
  a.lost = static_cast<int>(st->ColumnInt(1));
  a.workers = st->ColumnText(2);
  a.last_error = st->ColumnText(3);
  return std::optional<TaskAttempts>(std::move(a));
}

Status TaskStore::DeleteJob(int64_t job) {
  // Rare and small: through the read connection, serialised by SQLite's write lock.
  std::lock_guard<std::mutex> l(impl_->read_mu);
  for (const char* table : {"task_results", "task_attempts"}) {
    auto st = Statement::Prepare(impl_->read_db, std::string("DELETE FROM ") + table + " WHERE job_id = ?",
                                 std::string("delete ") + table);
    if (!st.ok()) return st.status();
    st->BindInt(1, job);
    WORMDRAG_RETURN_IF_ERROR(st->Run());
  }
  return Status::Ok();
}

}  // namespace wormdrag::server
