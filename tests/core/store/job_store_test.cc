// The job store's file, datasets and jobs: opening and refusing files, deduplicated
// recordings, job states and lookups, and what a failed or blocked write leaves.
#include "core/store/job_store.h"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <string>

#include "tests/core/store/store_testing.h"

namespace wormdrag {
namespace {

using store_testing::Eval;
using store_testing::JobStoreTest;
using store_testing::kInf;
using store_testing::MakeDataset;
using store_testing::MakeJob;
using store_testing::RawConnection;

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

}  // namespace
}  // namespace wormdrag
