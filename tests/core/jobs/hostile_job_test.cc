// Jobs whose recordings imply absurd work: refused at submission with the file and its
// fps named, and failed (never crashed) when such a job is already in the store.
#include <unistd.h>
#include <cstdio>

#include <gtest/gtest.h>

#include "core/common/guard.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"
#include "tests/core/jobs/hostile_inputs.h"

namespace wormdrag {
namespace {

using hostile::SlowFpsRecording;
JobOptions Options() {
  return hostile::SmallOptions();
}

class HostileJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = ::testing::TempDir() + "/hostile_job_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db";
    std::remove(path_.c_str());
    auto s = JobStore::Open(path_);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    store_ = std::move(*s);
    inputs_ = {JobInput{"slow.csv", SlowFpsRecording(1)}, JobInput{"L2.csv", SlowFpsRecording(2)}};
  }
  std::string path_;
  std::unique_ptr<JobStore> store_;
  std::array<JobInput, 2> inputs_;
};

TEST_F(HostileJobTest, TinyFpsIsRefusedAtSubmissionNamingFileAndField) {
  bool reused = false;
  auto id = SubmitEstimateJob(*store_, inputs_, Options(), true, &reused);
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.status().code(), Status::Code::kInvalidArgument);
  const std::string& m = id.status().message();
  EXPECT_NE(m.find("slow.csv: fps 0.001"), std::string::npos) << m;
  EXPECT_NE(m.find("'# fps'"), std::string::npos) << m;
  auto jobs = store_->ListJobs();
  ASSERT_TRUE(jobs.ok());
  EXPECT_TRUE(jobs->empty());
}

TEST_F(HostileJobTest, StoredJobWithTinyFpsFailsInsteadOfCrashing) {
  // As if stored by a coordinator that did not check the work: the runner must fail
  // the job with the reason (so a restart does not resume it).
  JobRecord job;
  job.kind = "estimate";
  const auto ds = DatasetRecords(inputs_, &job);
  job.options_json = Options().ToJson();
  job.eval_key = EvalKey(job.dataset_hashes, Options());
  auto id = store_->CreateJob(job, ds);
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  const Status st = RunEstimateJob(*store_, *id, LocalEvaluatorFactory(1));
  EXPECT_EQ(st.code(), Status::Code::kInvalidArgument) << st.ToString();
  auto stored = store_->GetJob(*id);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->state, JobState::kFailed);
  EXPECT_NE(stored->error.find("fps"), std::string::npos) << stored->error;
  auto resumable = store_->JobsInState(JobState::kRunning);
  ASSERT_TRUE(resumable.ok());
  EXPECT_TRUE(resumable->empty());
}

TEST(WorkBounds, SubstepsForAnAbsurdFpsDoNotOverflow) {
  EvaluationOptions e;
  EXPECT_EQ(e.SubstepsFor(1e-300), kMaxKnots);
  EXPECT_EQ(e.SubstepsFor(0.001), 600000);
  EXPECT_EQ(e.SubstepsFor(300), 2);
}

TEST(WorkBounds, ShapeDriveRefusesMoreKnotsThanItMayHold) {
  std::vector<double> times(5000);
  for (size_t i = 0; i < times.size(); ++i) times[i] = i * 0.01;
  BodyModel body;
  body.length = 1;
  auto d = ShapeDrive::FromFunction(times,
                                    [](double, Shape* q, Shape* qd) {
                                      q->fill(0.1);
                                      qd->fill(0);
                                    },
                                    body, Pose(), {1000});
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), Status::Code::kInvalidArgument);
  EXPECT_NE(d.status().message().find("solver knots"), std::string::npos) << d.status().message();
}

TEST(RunGuarded, TurnsEscapingExceptionsIntoStatus) {
  EXPECT_EQ(RunGuarded("x", []() -> Status { throw std::length_error("vector::reserve"); }).code(),
            Status::Code::kInternal);
  EXPECT_EQ(RunGuarded("x", []() -> Status { throw std::bad_alloc(); }).code(), Status::Code::kResourceExhausted);
  EXPECT_EQ(RunGuarded("x", []() -> Status { throw 42; }).code(), Status::Code::kInternal);
  EXPECT_TRUE(RunGuarded("x", [] { return Status::Ok(); }).ok());
}

}  // namespace
}  // namespace wormdrag
