#include "core/store/job_store.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <regex>
#include <thread>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

DatasetRecord MakeDataset(const std::string& name, const std::string& content) {
  return DatasetRecord{Sha256Hex(content), name, content};
}

JobRecord MakeJob(const std::string& eval_key, const std::string& options_json = "{\"seed\":1}") {
  JobRecord job;
  job.eval_key = eval_key;
  job.options_json = options_json;
  return job;
}

// Deterministic, distinct coefficient sets: callers generate sets the same way,
// so equal sets are bit-identical doubles.
Coefficients SetNumber(int i) {
  return {0.1 * i, 0.01 * i + 0.5, 0.003 * (i % 7), 0.001 * (i / 7)};
}

EvaluationRecord Eval(int phase, int i, double e) {
  return EvaluationRecord{phase, SetNumber(i), e};
}

// A second connection to the same file, as another process would have, to look
// at what is really on disk and to hold locks.
class RawConnection {
 public:
  explicit RawConnection(const std::string& path) {
    if (sqlite3_open(path.c_str(), &db_) != SQLITE_OK) ADD_FAILURE() << "raw open failed: " << sqlite3_errmsg(db_);
  }
  ~RawConnection() { sqlite3_close(db_); }
  int Exec(const std::string& sql) { return sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr); }
  std::string QueryText(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    std::string out = "<error>";
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW) {
      const unsigned char* text = sqlite3_column_text(st, 0);
      out = text ? reinterpret_cast<const char*>(text) : "<null>";
    }
    sqlite3_finalize(st);
    return out;
  }

 private:
  sqlite3* db_ = nullptr;
};

class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = ::testing::TempDir() + "wormdrag_store_" + info->name() + "_" + std::to_string(getpid()) + ".db";
    RemoveFiles();
    Reopen();
  }
  void TearDown() override {
    store_.reset();
    RemoveFiles();
  }
  void RemoveFiles() {
    for (const char* suffix : {"", "-wal", "-shm"}) std::remove((path_ + suffix).c_str());
  }
  void Reopen() {
    store_.reset();  // closes the previous connection first
    auto opened = JobStore::Open(path_);
    ASSERT_TRUE(opened.ok()) << opened.status().ToString();
    store_ = std::move(*opened);
  }
  int64_t CreateJob(const std::string& eval_key, const std::string& content1 = "k1 data",
                    const std::string& content2 = "k2 data") {
    auto id = store_->CreateJob(MakeJob(eval_key), {MakeDataset("k1.csv", content1), MakeDataset("k2.csv", content2)});
    EXPECT_TRUE(id.ok()) << id.status().ToString();
    return id.ok() ? *id : -1;
  }

  std::string path_;
  std::unique_ptr<JobStore> store_;
};

// ------------------------------------------------------------------ open

TEST_F(JobStoreTest, OpenSetsWalJournalAndSchemaVersion) {
  RawConnection raw(path_);
  EXPECT_EQ(raw.QueryText("PRAGMA journal_mode"), "wal");  // persistent in the file
  EXPECT_EQ(raw.QueryText("PRAGMA user_version"), "1");
  EXPECT_EQ(raw.QueryText("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN "
                          "('datasets', 'jobs', 'evaluations', 'survivors')"),
            "4");
}

TEST_F(JobStoreTest, OpenInMissingDirectoryFailsNamingThePath) {
  const std::string bad = ::testing::TempDir() + "no_such_dir_wormdrag/jobs.db";
  auto opened = JobStore::Open(bad);
  ASSERT_FALSE(opened.ok());
  EXPECT_NE(opened.status().message().find(bad + ": cannot open"), std::string::npos) << opened.status().ToString();
}

TEST_F(JobStoreTest, OpenRejectsAFileThatIsNotADatabase) {
  const std::string junk = path_ + ".junk";
  {
    std::ofstream out(junk);
    out << std::string(4096, 'x');
  }
  auto opened = JobStore::Open(junk);
  EXPECT_FALSE(opened.ok());
  std::remove(junk.c_str());
}

TEST_F(JobStoreTest, OpenRejectsANewerSchema) {
  store_.reset();
  {
    RawConnection raw(path_);
    ASSERT_EQ(raw.Exec("PRAGMA user_version = 2"), SQLITE_OK);
  }
  auto opened = JobStore::Open(path_);
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.status().code(), Status::Code::kFailedPrecondition) << opened.status().ToString();
}

// ------------------------------------------------------------------ states

TEST(JobStateTest, NamesRoundTrip) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kDone, JobState::kFailed, JobState::kCancelled}) {
    auto parsed = ParseJobState(JobStateName(s));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, s);
  }
  EXPECT_STREQ(JobStateName(JobState::kCancelled), "cancelled");
  EXPECT_EQ(ParseJobState("Done").status().code(), Status::Code::kInvalidArgument);
  EXPECT_EQ(ParseJobState("").status().code(), Status::Code::kInvalidArgument);
}

// ------------------------------------------------------------------ datasets

TEST_F(JobStoreTest, DatasetsAreDeduplicatedByHashAndKeepTheirBytes) {
  std::string content = "t,x\n0,1\n";
  content.push_back('\0');  // binary-safe: NUL and high bytes survive
  content += "\xff\xfe tail";
  const DatasetRecord first = MakeDataset("first.csv", content);
  ASSERT_TRUE(store_->PutDataset(first).ok());
  ASSERT_TRUE(store_->PutDataset(MakeDataset("second-name.csv", content)).ok());  // a no-op

  auto got = store_->GetDataset(first.hash);
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  EXPECT_EQ(got->hash, first.hash);
  EXPECT_EQ(got->name, "first.csv");  // immutable: the first submission's name
  EXPECT_EQ(got->content, content);

  RawConnection raw(path_);
  EXPECT_EQ(raw.QueryText("SELECT count(*) FROM datasets"), "1");
}

TEST_F(JobStoreTest, EmptyDatasetIsStoredAsEmptyNotNull) {
  const DatasetRecord empty = MakeDataset("empty.csv", "");
  ASSERT_TRUE(store_->PutDataset(empty).ok());
  auto got = store_->GetDataset(empty.hash);
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  EXPECT_EQ(got->content, "");
}

TEST_F(JobStoreTest, DatasetWithWrongHashIsRejected) {
  DatasetRecord d = MakeDataset("k.csv", "some data");
  d.content += "tampered";
  Status s = store_->PutDataset(d);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << s.ToString();
  EXPECT_EQ(store_->GetDataset(d.hash).status().code(), Status::Code::kNotFound);

  DatasetRecord no_hash{"", "k.csv", "x"};
  EXPECT_EQ(store_->PutDataset(no_hash).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, UnknownDatasetIsNotFound) {
  auto got = store_->GetDataset(Sha256Hex("never stored"));
  EXPECT_EQ(got.status().code(), Status::Code::kNotFound) << got.status().ToString();
}

// ------------------------------------------------------------------ jobs

TEST_F(JobStoreTest, CreateAndGetJob) {
  JobRecord job = MakeJob("key-A", "{\"grid\":5}");
  job.kind = "diagnose";
  job.state = JobState::kDone;  // ignored: a new job is queued
  const DatasetRecord k1 = MakeDataset("K1.csv", "first recording");
  const DatasetRecord k2 = MakeDataset("K2.csv", "second recording");
  auto id = store_->CreateJob(job, {k1, k2});
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  EXPECT_GT(*id, 0);

  auto got = store_->GetJob(*id);
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  EXPECT_EQ(got->id, *id);
  EXPECT_EQ(got->kind, "diagnose");
  EXPECT_EQ(got->state, JobState::kQueued);
  EXPECT_EQ(got->eval_key, "key-A");
  EXPECT_EQ(got->options_json, "{\"grid\":5}");
  EXPECT_EQ(got->dataset_hashes[0], k1.hash);
  EXPECT_EQ(got->dataset_hashes[1], k2.hash);
  EXPECT_EQ(got->dataset_names[0], "K1.csv");
  EXPECT_EQ(got->dataset_names[1], "K2.csv");
  const std::regex iso8601(R"(\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}\.\d{3}Z)");
  EXPECT_TRUE(std::regex_match(got->created_at, iso8601)) << got->created_at;
  EXPECT_EQ(got->updated_at, got->created_at);

  // The datasets went in with the job.
  auto d1 = store_->GetDataset(k1.hash);
  ASSERT_TRUE(d1.ok());
  EXPECT_EQ(d1->content, "first recording");
  EXPECT_TRUE(store_->GetDataset(k2.hash).ok());
}

TEST_F(JobStoreTest, JobsSharingARecordingStoreItOnce) {
  CreateJob("a", "shared", "only in job 1");
  CreateJob("b", "shared", "only in job 2");
  RawConnection raw(path_);
  EXPECT_EQ(raw.QueryText("SELECT count(*) FROM datasets"), "3");
}

TEST_F(JobStoreTest, JobWithOneRecording) {
  auto id = store_->CreateJob(MakeJob("k"), {MakeDataset("only.csv", "x"), DatasetRecord{}});
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  auto got = store_->GetJob(*id);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->dataset_hashes[1], "");
  EXPECT_EQ(got->dataset_names[1], "");

  auto none = store_->CreateJob(MakeJob("k"), {DatasetRecord{}, DatasetRecord{}});
  EXPECT_EQ(none.status().code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, CreateJobRejectsHashesThatDoNotMatchTheInputs) {
  JobRecord job = MakeJob("k");
  job.dataset_hashes[0] = Sha256Hex("something else");
  auto id = store_->CreateJob(job, {MakeDataset("a", "a"), MakeDataset("b", "b")});
  EXPECT_EQ(id.status().code(), Status::Code::kInvalidArgument) << id.status().ToString();
}

TEST_F(JobStoreTest, ListJobsNewestFirstWithLimit) {
  const int64_t a = CreateJob("a"), b = CreateJob("b"), c = CreateJob("c");
  auto all = store_->ListJobs();
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[0].id, c);
  EXPECT_EQ((*all)[1].id, b);
  EXPECT_EQ((*all)[2].id, a);

  auto two = store_->ListJobs(2);
  ASSERT_TRUE(two.ok());
  ASSERT_EQ(two->size(), 2u);
  EXPECT_EQ((*two)[0].id, c);
  EXPECT_EQ((*two)[1].id, b);

  EXPECT_EQ(store_->ListJobs(-1).status().code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, CountJobsByStateNamesEveryState) {
  auto none = store_->CountJobsByState();
  ASSERT_TRUE(none.ok()) << none.status().ToString();
  EXPECT_EQ(none->size(), 5u);
  for (const auto& [state, n] : *none) EXPECT_EQ(n, 0) << JobStateName(state);
  const int64_t a = CreateJob("a"), b = CreateJob("b");
  CreateJob("c");
  ASSERT_TRUE(store_->SetState(a, JobState::kRunning).ok());
  ASSERT_TRUE(store_->SetState(b, JobState::kFailed, "boom").ok());
  auto counts = store_->CountJobsByState();
  ASSERT_TRUE(counts.ok());
  EXPECT_EQ(counts->at(JobState::kQueued), 1);
  EXPECT_EQ(counts->at(JobState::kRunning), 1);
  EXPECT_EQ(counts->at(JobState::kFailed), 1);
  EXPECT_EQ(counts->at(JobState::kDone), 0);
  EXPECT_EQ(counts->at(JobState::kCancelled), 0);
}

TEST_F(JobStoreTest, JobsInStateOldestFirst) {
  const int64_t a = CreateJob("a"), b = CreateJob("b"), c = CreateJob("c"), d = CreateJob("d");
  ASSERT_TRUE(store_->SetState(c, JobState::kRunning).ok());
  ASSERT_TRUE(store_->SetState(a, JobState::kRunning).ok());
  ASSERT_TRUE(store_->SetState(d, JobState::kDone).ok());

  auto running = store_->JobsInState(JobState::kRunning);
  ASSERT_TRUE(running.ok());
  ASSERT_EQ(running->size(), 2u);
  EXPECT_EQ((*running)[0].id, a);
  EXPECT_EQ((*running)[1].id, c);

  auto queued = store_->JobsInState(JobState::kQueued);
  ASSERT_TRUE(queued.ok());
  ASSERT_EQ(queued->size(), 1u);
  EXPECT_EQ((*queued)[0].id, b);

  auto cancelled = store_->JobsInState(JobState::kCancelled);
  ASSERT_TRUE(cancelled.ok());
  EXPECT_TRUE(cancelled->empty());
}

TEST_F(JobStoreTest, StateTransitionsErrorsAndResult) {
  const int64_t id = CreateJob("k");
  const std::string created_at = store_->GetJob(id)->created_at;

  ASSERT_TRUE(store_->SetState(id, JobState::kRunning).ok());
  EXPECT_EQ(store_->GetJob(id)->state, JobState::kRunning);

  ASSERT_TRUE(store_->SetState(id, JobState::kFailed, "simulation diverged at set 12").ok());
  auto failed = store_->GetJob(id);
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_EQ(failed->error, "simulation diverged at set 12");
  EXPECT_GE(failed->updated_at, created_at);  // ISO 8601 strings sort in time order

  // Re-run after a restart: the old reason goes away.
  ASSERT_TRUE(store_->SetState(id, JobState::kRunning).ok());
  EXPECT_EQ(store_->GetJob(id)->error, "");

  ASSERT_TRUE(store_->SetResult(id, "{\"mu_n\":0.5}").ok());
  auto done = store_->GetJob(id);
  EXPECT_EQ(done->state, JobState::kDone);
  EXPECT_EQ(done->result_json, "{\"mu_n\":0.5}");
  EXPECT_EQ(done->created_at, created_at);
}

TEST_F(JobStoreTest, Progress) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->SetProgress(id, "phase2", 120, 625, 0.0375).ok());
  auto got = store_->GetJob(id);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->phase, "phase2");
  EXPECT_EQ(got->sets_done, 120);
  EXPECT_EQ(got->sets_total, 625);
  EXPECT_EQ(got->best_e, 0.0375);
  EXPECT_EQ(got->state, JobState::kQueued);  // progress does not change the state

  ASSERT_TRUE(store_->SetProgress(id, "phase3", 0, 0, kInf).ok());  // no finite E yet
  EXPECT_EQ(store_->GetJob(id)->best_e, kInf);
  EXPECT_EQ(store_->SetProgress(id, "phase3", -1, 0, 0).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, FindDoneJobMatchesKeyAndOptionsOfFinishedJobsOnly) {
  JobRecord job = MakeJob("key-A", "{\"o\":1}");
  const DatasetRecord k1 = MakeDataset("a", "a"), k2 = MakeDataset("b", "b");
  const int64_t running = *store_->CreateJob(job, {k1, k2});
  ASSERT_TRUE(store_->SetState(running, JobState::kRunning).ok());

  auto none = store_->FindDoneJob("key-A", "{\"o\":1}");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());  // not finished

  const int64_t done = *store_->CreateJob(job, {k1, k2});
  ASSERT_TRUE(store_->SetResult(done, "{}").ok());
  auto found = store_->FindDoneJob("key-A", "{\"o\":1}");
  ASSERT_TRUE(found.ok());
  ASSERT_TRUE(found->has_value());
  EXPECT_EQ(**found, done);

  EXPECT_FALSE(store_->FindDoneJob("key-A", "{\"o\":2}")->has_value());
  EXPECT_FALSE(store_->FindDoneJob("key-B", "{\"o\":1}")->has_value());
}

TEST_F(JobStoreTest, UnknownJobIsNotFoundEverywhere) {
  const int64_t missing = 4242;
  std::vector<std::optional<double>> unused;
  EXPECT_EQ(store_->GetJob(missing).status().code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->SetState(missing, JobState::kRunning).code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->SetProgress(missing, "phase1", 1, 2, 3).code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->SetResult(missing, "{}").code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->PutEvaluations(missing, {Eval(1, 1, 1.0)}).code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->PutEvaluations(missing, {}).code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->Evaluations(missing).status().code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->CountEvaluations(missing).status().code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->PutSurvivors(missing, 1, {Eval(1, 1, 1.0)}).code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->Survivors(missing, 1).status().code(), Status::Code::kNotFound);
  Status s = store_->GetJob(missing).status();
  EXPECT_NE(s.message().find("job 4242"), std::string::npos) << s.ToString();
}

// ------------------------------------------------------------------ evaluations

TEST_F(JobStoreTest, PutEvaluationsIsIdempotentFirstValueWins) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 0.5), Eval(1, 2, 0.25)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 0.5), Eval(1, 2, 0.25)}).ok());  // the same batch again
  EXPECT_EQ(*store_->CountEvaluations(id), 2);

  // A different E for a stored set is ignored; the new set is added.
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 99.0), Eval(1, 3, 0.75)}).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 3);
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  for (const EvaluationRecord& r : *all) {
    if (r.set == SetNumber(1)) { EXPECT_EQ(r.e, 0.5); }
  }

  // The same set in another phase is another evaluation.
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(2, 1, 0.4)}).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 4);
  EXPECT_EQ(*store_->CountEvaluations(id, 1), 3);
  EXPECT_EQ(*store_->CountEvaluations(id, 2), 1);
}

TEST_F(JobStoreTest, InfiniteERoundTrips) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, kInf), Eval(1, 2, 1.5)}).ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].e, 1.5);  // finite before infinite
  EXPECT_TRUE(std::isinf((*all)[1].e) && (*all)[1].e > 0) << (*all)[1].e;
  EXPECT_EQ((*all)[1].set, SetNumber(1));

  std::vector<std::optional<double>> found;
  ASSERT_TRUE(store_->LookupEvaluations("k", {SetNumber(1)}, &found).ok());
  ASSERT_TRUE(found[0].has_value());
  EXPECT_EQ(*found[0], kInf);

  RawConnection raw(path_);
  EXPECT_EQ(raw.QueryText("SELECT typeof(e) FROM evaluations WHERE e > 1e308"), "real");  // not NULL, not text
}

TEST_F(JobStoreTest, CoefficientsRoundTripBitExactly) {
  const int64_t id = CreateJob("k");
  const Coefficients awkward{0.1 + 0.2, 1.0 / 3.0, 5e-324, 1.7976931348623157e308};
  ASSERT_TRUE(store_->PutEvaluations(id, {EvaluationRecord{1, awkward, 0.1 * 3}}).ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 1u);
  EXPECT_EQ((*all)[0].set, awkward);
  EXPECT_EQ((*all)[0].e, 0.1 * 3);
  std::vector<std::optional<double>> found;
  ASSERT_TRUE(
      store_->LookupEvaluations("k", {awkward, Coefficients{0.3, 1.0 / 3.0, 5e-324, 1.7976931348623157e308}}, &found)
          .ok());
  EXPECT_TRUE(found[0].has_value());
  EXPECT_FALSE(found[1].has_value());  // 0.3 != 0.1 + 0.2: compared exactly
}

TEST_F(JobStoreTest, LookupFindsSetsOfAnyJobWithTheSameKeyOnly) {
  const int64_t first = CreateJob("key-A");
  const int64_t second = CreateJob("key-A");
  const int64_t other = CreateJob("key-B");
  ASSERT_TRUE(store_->PutEvaluations(first, {Eval(1, 1, 0.1), Eval(1, 2, 0.2)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(second, {Eval(2, 3, 0.3)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(other, {Eval(1, 4, 0.4)}).ok());

  std::vector<std::optional<double>> found;
  ASSERT_TRUE(
      store_->LookupEvaluations("key-A", {SetNumber(1), SetNumber(3), SetNumber(4), SetNumber(5)}, &found).ok());
  ASSERT_EQ(found.size(), 4u);
  EXPECT_EQ(found[0], std::optional<double>(0.1));
  EXPECT_EQ(found[1], std::optional<double>(0.3));  // stored by the second job
  EXPECT_FALSE(found[2].has_value());               // stored under key-B
  EXPECT_FALSE(found[3].has_value());               // never evaluated

  ASSERT_TRUE(store_->LookupEvaluations("key-B", {SetNumber(1), SetNumber(4)}, &found).ok());
  ASSERT_EQ(found.size(), 2u);
  EXPECT_FALSE(found[0].has_value());
  EXPECT_EQ(found[1], std::optional<double>(0.4));

  ASSERT_TRUE(store_->LookupEvaluations("key-C", {}, &found).ok());
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(store_->LookupEvaluations("", {SetNumber(1)}, &found).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, EvaluationsBestFirstFilteredAndLimited) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_
                  ->PutEvaluations(id, {Eval(1, 1, 0.9), Eval(1, 2, 0.1), Eval(2, 3, 0.5), Eval(1, 4, kInf),
                                        Eval(2, 5, 0.05), Eval(1, 6, 0.3)})
                  .ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  std::vector<double> es;
  for (const auto& r : *all) es.push_back(r.e);
  EXPECT_EQ(es, (std::vector<double>{0.05, 0.1, 0.3, 0.5, 0.9, kInf}));
  EXPECT_EQ((*all)[0].phase, 2);
  EXPECT_EQ((*all)[0].set, SetNumber(5));

  auto phase1 = store_->Evaluations(id, 1);
  ASSERT_TRUE(phase1.ok());
  es.clear();
  for (const auto& r : *phase1) {
    es.push_back(r.e);
    EXPECT_EQ(r.phase, 1);
  }
  EXPECT_EQ(es, (std::vector<double>{0.1, 0.3, 0.9, kInf}));

  auto best2 = store_->Evaluations(id, 1, 2);
  ASSERT_TRUE(best2.ok());
  ASSERT_EQ(best2->size(), 2u);
  EXPECT_EQ((*best2)[0].set, SetNumber(2));
  EXPECT_EQ((*best2)[1].set, SetNumber(6));

  auto none = store_->Evaluations(id, 3);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

// A batch is one transaction: a bad row in the middle leaves none of it stored.
TEST_F(JobStoreTest, FailedBatchStoresNothing) {
  const int64_t id = CreateJob("k");
  std::vector<EvaluationRecord> batch;
  for (int i = 0; i < 100; ++i) batch.push_back(Eval(1, i, 0.01 * i));
  batch[50].e = std::numeric_limits<double>::quiet_NaN();  // SQLite would store NULL: rejected by NOT NULL
  Status s = store_->PutEvaluations(id, batch);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << s.ToString();
  EXPECT_NE(s.message().find("evaluation 50 of 100"), std::string::npos) << s.ToString();
  EXPECT_EQ(*store_->CountEvaluations(id), 0);

  batch[50].e = 0.5;
  batch[99].phase = 0;  // violates CHECK (phase >= 1) on the last row
  EXPECT_FALSE(store_->PutEvaluations(id, batch).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 0);

  batch[99].phase = 1;
  ASSERT_TRUE(store_->PutEvaluations(id, batch).ok());  // the store is still usable
  EXPECT_EQ(*store_->CountEvaluations(id), 100);
}

// CreateJob writes the datasets, then the job; the job row is rejected by the
// schema's CHECK on kind, after both datasets were inserted in the transaction.
TEST_F(JobStoreTest, FailedCreateJobLeavesNoDatasetsBehind) {
  JobRecord job = MakeJob("k");
  job.kind = "not-a-kind";
  const DatasetRecord k1 = MakeDataset("k1", "fresh one"), k2 = MakeDataset("k2", "fresh two");
  auto id = store_->CreateJob(job, {k1, k2});
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.status().code(), Status::Code::kInvalidArgument) << id.status().ToString();
  EXPECT_NE(id.status().message().find("insert job"), std::string::npos) << id.status().ToString();

  EXPECT_EQ(store_->GetDataset(k1.hash).status().code(), Status::Code::kNotFound);
  EXPECT_EQ(store_->GetDataset(k2.hash).status().code(), Status::Code::kNotFound);
  EXPECT_TRUE(store_->ListJobs()->empty());
}

// Another process holding the write lock past busy_timeout: the write fails as
// UNAVAILABLE (retryable) and nothing is stored. Takes busy_timeout (5 s).
TEST_F(JobStoreTest, WriteBlockedByAnotherConnectionFailsCleanly) {
  const int64_t id = CreateJob("k");
  RawConnection other(path_);
  ASSERT_EQ(other.Exec("BEGIN IMMEDIATE"), SQLITE_OK);
  Status s = store_->PutEvaluations(id, {Eval(1, 1, 1.0)});
  EXPECT_EQ(s.code(), Status::Code::kUnavailable) << s.ToString();
  ASSERT_EQ(other.Exec("ROLLBACK"), SQLITE_OK);
  EXPECT_EQ(*store_->CountEvaluations(id), 0);
  EXPECT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 1.0)}).ok());
}

// ------------------------------------------------------------------ survivors

TEST_F(JobStoreTest, SurvivorsReplaceAndKeepRankOrder) {
  const int64_t id = CreateJob("k");
  // Rank order is the caller's, not E order.
  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 7, 0.3), Eval(1, 8, 0.1), Eval(1, 9, 0.2)}).ok());
  ASSERT_TRUE(store_->PutSurvivors(id, 2, {Eval(2, 1, 0.05)}).ok());
  auto d1 = store_->Survivors(id, 1);
  ASSERT_TRUE(d1.ok());
  ASSERT_EQ(d1->size(), 3u);
  EXPECT_EQ((*d1)[0].set, SetNumber(7));
  EXPECT_EQ((*d1)[1].set, SetNumber(8));
  EXPECT_EQ((*d1)[2].set, SetNumber(9));
  EXPECT_EQ((*d1)[1].e, 0.1);
  EXPECT_EQ((*d1)[0].phase, 1);

  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 2, 0.01), Eval(1, 3, 0.02)}).ok());
  d1 = store_->Survivors(id, 1);
  ASSERT_EQ(d1->size(), 2u);  // replaced, not appended
  EXPECT_EQ((*d1)[0].set, SetNumber(2));
  EXPECT_EQ((*d1)[1].set, SetNumber(3));
  EXPECT_EQ(store_->Survivors(id, 2)->size(), 1u);  // the other phase untouched

  ASSERT_TRUE(store_->PutSurvivors(id, 1, {}).ok());
  EXPECT_TRUE(store_->Survivors(id, 1)->empty());
  EXPECT_EQ(store_->PutSurvivors(id, 0, {}).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, FailedSurvivorReplacementKeepsThePreviousOnes) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 1, 0.1), Eval(1, 2, 0.2)}).ok());
  std::vector<EvaluationRecord> bad = {Eval(1, 3, 0.3), Eval(1, 4, std::numeric_limits<double>::quiet_NaN())};
  EXPECT_FALSE(store_->PutSurvivors(id, 1, bad).ok());
  auto d1 = store_->Survivors(id, 1);
  ASSERT_TRUE(d1.ok());
  ASSERT_EQ(d1->size(), 2u);
  EXPECT_EQ((*d1)[0].set, SetNumber(1));
  EXPECT_EQ((*d1)[1].set, SetNumber(2));
}

// ------------------------------------------------------------------ durability, threads, volume

TEST_F(JobStoreTest, EverythingSurvivesCloseAndReopen) {
  const DatasetRecord k1 = MakeDataset("K1.csv", "recording one"), k2 = MakeDataset("K2.csv", "recording two");
  const int64_t id = *store_->CreateJob(MakeJob("key-R", "{\"r\":1}"), {k1, k2});
  ASSERT_TRUE(store_->SetState(id, JobState::kRunning).ok());
  ASSERT_TRUE(store_->SetProgress(id, "phase1", 3, 10, 0.2).ok());
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 0.2), Eval(1, 2, kInf), Eval(1, 3, 0.7)}).ok());
  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 1, 0.2), Eval(1, 3, 0.7)}).ok());
  const int64_t finished = CreateJob("key-F");
  ASSERT_TRUE(store_->SetResult(finished, "{\"done\":true}").ok());

  Reopen();

  auto job = store_->GetJob(id);
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->state, JobState::kRunning);
  EXPECT_EQ(job->phase, "phase1");
  EXPECT_EQ(job->sets_done, 3);
  EXPECT_EQ(job->best_e, 0.2);
  EXPECT_EQ(store_->GetDataset(k2.hash)->content, "recording two");
  EXPECT_EQ(*store_->CountEvaluations(id), 3);
  EXPECT_EQ(store_->Evaluations(id)->back().e, kInf);
  EXPECT_EQ(store_->Survivors(id, 1)->size(), 2u);
  EXPECT_EQ(store_->JobsInState(JobState::kRunning)->size(), 1u);
  EXPECT_EQ(store_->GetJob(finished)->result_json, "{\"done\":true}");
  EXPECT_EQ(**store_->FindDoneJob("key-F", "{\"seed\":1}"), finished);

  // New ids continue after the old ones.
  EXPECT_GT(CreateJob("key-N"), finished);
}

TEST_F(JobStoreTest, ConcurrentBatchesFromFourThreadsLoseNothing) {
  const int64_t id = CreateJob("k");
  constexpr int kThreads = 4, kBatches = 20, kPerBatch = 50;
  std::atomic<int> failures{0};
  std::atomic<bool> writing{true};
  std::vector<std::thread> writers;
  for (int t = 0; t < kThreads; ++t) {
    writers.emplace_back([&, t] {
      for (int b = 0; b < kBatches; ++b) {
        std::vector<EvaluationRecord> batch;
        for (int i = 0; i < kPerBatch; ++i) {
          const int n = (t * kBatches + b) * kPerBatch + i;  // distinct across threads
          batch.push_back(Eval(1, n, 0.001 * n));
        }
        batch.push_back(Eval(1, -1 - b, 100.0 + t));  // the same sets from every thread
        if (!store_->PutEvaluations(id, batch).ok()) ++failures;
      }
    });
  }
  // A reader at the same time: it must never see an error.
  std::thread reader([&] {
    std::vector<std::optional<double>> found;
    while (writing) {
      if (!store_->CountEvaluations(id).ok()) ++failures;
      if (!store_->LookupEvaluations("k", {SetNumber(0), SetNumber(-1)}, &found).ok()) ++failures;
    }
  });
  for (auto& w : writers) w.join();
  writing = false;
  reader.join();

  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(*store_->CountEvaluations(id), kThreads * kBatches * kPerBatch + kBatches);
  std::vector<Coefficients> shared;
  for (int b = 0; b < kBatches; ++b) shared.push_back(SetNumber(-1 - b));
  std::vector<std::optional<double>> found;
  ASSERT_TRUE(store_->LookupEvaluations("k", shared, &found).ok());
  for (const auto& e : found) {
    ASSERT_TRUE(e.has_value());
    EXPECT_TRUE(*e == 100.0 || *e == 101.0 || *e == 102.0 || *e == 103.0) << *e;  // one thread's value, whole
  }
}

TEST_F(JobStoreTest, TenThousandRowBatchInOneCall) {
  const int64_t id = CreateJob("k");
  constexpr int kRows = 10000;
  std::vector<EvaluationRecord> batch;
  batch.reserve(kRows);
  for (int i = 0; i < kRows; ++i) batch.push_back(Eval(1 + i % 3, i, i % 97 == 1 ? kInf : 1.0 + (i * 7919) % kRows));
  const auto start = std::chrono::steady_clock::now();
  Status s = store_->PutEvaluations(id, batch);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(s.ok()) << s.ToString();
  std::cout << "[ timing   ] PutEvaluations of " << kRows << " rows: " << seconds * 1e3 << " ms\n";
  RecordProperty("put_10000_ms", std::to_string(seconds * 1e3));

  EXPECT_EQ(*store_->CountEvaluations(id), kRows);
  std::vector<Coefficients> sets;
  for (int i = 0; i < kRows; ++i) sets.push_back(SetNumber(i));
  std::vector<std::optional<double>> found;
  const auto lookup_start = std::chrono::steady_clock::now();
  ASSERT_TRUE(store_->LookupEvaluations("k", sets, &found).ok());
  const double lookup_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - lookup_start).count();
  std::cout << "[ timing   ] LookupEvaluations of " << kRows << " sets: " << lookup_seconds * 1e3 << " ms\n";
  for (int i = 0; i < kRows; ++i) {
    ASSERT_TRUE(found[i].has_value()) << i;
    ASSERT_EQ(*found[i], batch[i].e) << i;
  }
  auto best = store_->Evaluations(id, 0, 3);
  ASSERT_TRUE(best.ok());
  ASSERT_EQ(best->size(), 3u);
  EXPECT_EQ((*best)[0].e, 1.0);  // (i * 7919) % 10000 == 0 only for i = 0
  EXPECT_LE((*best)[0].e, (*best)[1].e);
  EXPECT_LE((*best)[1].e, (*best)[2].e);
}

}  // namespace
}  // namespace wormdrag
