// The evaluated sets of every job, shared by eval_key, and the survivors each phase
// ranks (SqliteJobStore, core/store/sqlite_job_store.h).
#include <string>
#include <utility>
#include <vector>

#include "core/store/sqlite_job_store.h"

namespace wormdrag::store_internal {
namespace {

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

// Every row a statement of evaluation columns (from the first) returns.
Result<std::vector<EvaluationRecord>> ReadEvaluations(Statement& st) {
  std::vector<EvaluationRecord> records;
  while (true) {
    auto row = st.Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    records.push_back(ReadEvaluation(st, 0));
  }
  return records;
}

}  // namespace

Result<Transaction> SqliteJobStore::BeginOnJob(int64_t id, Transaction::Mode mode, const std::string& what) {
  auto tx = Transaction::Begin(db_, mode, what);
  if (!tx.ok()) return tx.status();
  auto exists = JobEvalKey(id);
  if (!exists.ok()) return exists.status();
  return tx;
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
  auto tx = BeginOnJob(job, Transaction::Mode::kRead, "read evaluations");
  if (!tx.ok()) return tx.status();
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
  return ReadEvaluations(*st);
}

Result<int64_t> SqliteJobStore::CountEvaluations(int64_t job, int phase) {
  if (phase < 0) return Invalid("count evaluations of job " + std::to_string(job) + ": phase must be >= 0");
  std::lock_guard<std::mutex> lock(mutex_);
  auto tx = BeginOnJob(job, Transaction::Mode::kRead, "count evaluations");
  if (!tx.ok()) return tx.status();
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
  auto tx = BeginOnJob(job, Transaction::Mode::kWrite, "store survivors");
  if (!tx.ok()) return tx.status();
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
  auto tx = BeginOnJob(job, Transaction::Mode::kRead, "read survivors");
  if (!tx.ok()) return tx.status();
  auto st = Statement::Prepare(db_,
                               "SELECT phase, mu_n, mu_t, eta_n, eta_t, e FROM survivors "
                               "WHERE job_id = ?1 AND phase = ?2 ORDER BY rank",
                               "read survivors of job " + std::to_string(job));
  if (!st.ok()) return st.status();
  st->BindInt(1, job);
  st->BindInt(2, phase);
  return ReadEvaluations(*st);
}

}  // namespace wormdrag::store_internal
