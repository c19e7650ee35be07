// Spot-checks of workers' results and the worker registry's expiry, with a clock
// moved by hand (server/spot_check.h, server/scheduler_spot.cc).
#include "server/spot_check.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "tests/server/scheduler_fixture.h"

namespace wormdrag::server {
namespace {

using namespace std::chrono_literals;

TEST(SpotCheck, TheChoiceIsDeterministicAndNearTheFraction) {
  int chosen = 0;
  for (int i = 0; i < 20000; ++i) {
    const Coefficients set{0.1 * i, 0.2, 0.001, 0.002};
    const std::string id = MakeTaskId(1, true, TaskKind::kMeanDistance, &set, 1);
    EXPECT_EQ(IsSpotChecked(id, 0.02), IsSpotChecked(id, 0.02));
    EXPECT_FALSE(IsSpotChecked(id, 0));
    EXPECT_TRUE(IsSpotChecked(id, 1));
    chosen += IsSpotChecked(id, 0.02);
  }
  EXPECT_GT(chosen, 300);  // 400 expected
  EXPECT_LT(chosen, 500);
  EXPECT_FALSE(IsSpotCheckable(TaskKind::kDiagnoseFit));
  EXPECT_FALSE(IsSpotCheckable(TaskKind::kBootstrapReplicate));
  EXPECT_TRUE(IsSpotCheckable(TaskKind::kResidualJacobians));
}

// A result of E values only.
TaskResult values(std::vector<double> v) {
  TaskResult r;
  r.values = std::move(v);
  return r;
}

TEST(SpotCheck, ResultsAgreeWithinTheLastBitsOnly) {
  const double tol = 1e-12;
  const TaskSpec exact;
  auto phase = [](int64_t keep, double cut) {
    TaskSpec t;
    t.keep = keep;
    t.cut = cut;
    return t;
  };
  EXPECT_TRUE(ResultsAgree(values({0.5, 2.0}), values({0.5 * (1 + 1e-15), 2.0}), tol, exact));
  EXPECT_FALSE(ResultsAgree(values({0.5, 2.0}), values({0.5 * (1 + 1e-9), 2.0}), tol, exact));
  EXPECT_FALSE(ResultsAgree(values({0.5}), values({0.5, 0.5}), tol, exact));
  // Abandoned by one worker only (task cut 0.6, keep 1): fine above the cut that worker
  // can have reached, wrong below it.
  EXPECT_TRUE(ResultsAgree(values({NAN, 1.0}), values({0.7, 1.0}), tol, phase(1, 0.6)));
  EXPECT_FALSE(ResultsAgree(values({NAN, 1.0}), values({0.5, 1.0}), tol, phase(1, 0.6)));
  // Its own completed E tightens its cut: with 0.3 done, abandoning 0.5 is legitimate.
  EXPECT_TRUE(ResultsAgree(values({NAN, 0.3}), values({0.5, 0.3}), tol, phase(1, 0.6)));
  EXPECT_FALSE(ResultsAgree(values({NAN, 0.3}), values({0.5, 0.3}), tol, phase(2, 0.6)));
  // Without abandoning a NaN agrees only with a NaN.
  EXPECT_FALSE(ResultsAgree(values({NAN, 1.0}), values({0.7, 1.0}), tol, exact));
  EXPECT_TRUE(ResultsAgree(values({NAN, 1.0}), values({NAN, 1.0}), tol, exact));
  EXPECT_TRUE(ResultsAgree(values({INFINITY}), values({INFINITY}), tol, exact));
  EXPECT_FALSE(ResultsAgree(values({INFINITY}), values({1e300}), tol, exact));
  EXPECT_TRUE(ResultsAgree(values({0.0}), values({0.0}), tol, exact));
  TaskResult a, b;
  a.residuals = b.residuals = {{1.0, 2.0}, {3.0}};
  a.jacobians = b.jacobians = {{1, 2, 3, 4, 5, 6, 7, 8}, {1, 2, 3, 4}};
  EXPECT_TRUE(ResultsAgree(a, b, tol, exact));
  b.jacobians[1][3] = 4.001;
  EXPECT_FALSE(ResultsAgree(a, b, tol, exact));
}

// Group cuts (Phase 3's scale rays): each set is bounded by its own group's cut and
// by the best value the worker completed in that group, never by another group's.
TEST(SpotCheck, GroupCutsBoundEachSetByItsOwnGroup) {
  const double tol = 1e-12;
  TaskSpec rays;
  rays.set_cuts = {0.6, 0.6, 2.0, 2.0};
  rays.set_groups = {0, 0, 2, 2};
  // Set 0 above its group's cut 0.6: may be abandoned; at 0.5 it may not.
  EXPECT_TRUE(ResultsAgree(values({NAN, 1.0, 1.5, 1.2}), values({0.7, 1.0, 1.5, 1.2}), tol, rays));
  EXPECT_FALSE(ResultsAgree(values({NAN, 1.0, 1.5, 1.2}), values({0.5, 1.0, 1.5, 1.2}), tol, rays));
  // Set 2 at 1.5 lies below its own cut 2.0 but above its group's completed 1.2.
  EXPECT_TRUE(ResultsAgree(values({0.7, 1.0, NAN, 1.2}), values({0.7, 1.0, 1.5, 1.2}), tol, rays));
  // Group 0's completed 0.7 does not bound group 2: 1.1 is below 1.2 and 2.0.
  EXPECT_FALSE(ResultsAgree(values({0.7, 1.0, NAN, 1.2}), values({0.7, 1.0, 1.1, 1.2}), tol, rays));
}

// Every task spot-checked; leases of 10 s; the test calls ReapExpired().
class SpotTest : public SchedulerFixture {
 protected:
  void SetUp() override {
    SchedulerFixture::SetUp();
    options_.spot_check_fraction = 1;
  }
};

// The first result is held back (not stored, its job not answered) until a different
// worker's agrees.
TEST_F(SpotTest, ASecondWorkerConfirmsAResultBeforeItIsStored) {
  Scheduler& s = Start({"w1", "w2"});
  RunIdsInBackground({"t1-a"});
  const LeasedTask first = MustLease("w1");
  ASSERT_TRUE(Report(first, "w1", 0.5).ok());
  EXPECT_FALSE(Stored("t1-a"));
  TaskResult again;
  again.values = {0.5};
  bool duplicate = false;
  ASSERT_TRUE(s.Report("w1", "t1-a", first.lease_id, again, "", &duplicate).ok());
  EXPECT_TRUE(duplicate) << "a repeated report while the check waits is a duplicate";
  EXPECT_EQ(s.Counters().queued, 1);
  EXPECT_FALSE(Poll("w1")) << "the worker that gave the first result checked itself";
  const LeasedTask second = MustLease("w2");
  EXPECT_EQ(second.spec.id, "t1-a");
  ASSERT_TRUE(Report(second, "w2", 0.5 * (1 + 1e-14)).ok());
  run_.join();
  ASSERT_TRUE(run_status_.ok()) << run_status_.ToString();
  ASSERT_EQ(results_.size(), 1u);
  EXPECT_EQ(results_[0].values[0], 0.5) << "the first of two agreeing results is kept";
  EXPECT_TRUE(Stored("t1-a"));
  EXPECT_EQ(s.Counters().spot_checks_total, 1);
  EXPECT_EQ(s.Counters().spot_mismatches_total, 0);
}

// Two results differ: a third worker decides, the odd one out is quarantined (no
// more tasks, its reports refused) and its result is not used.
TEST_F(SpotTest, TheOddOneOutIsQuarantinedAndItsResultIsNotUsed) {
  Scheduler& s = Start({"rogue", "w2", "w3"});
  RunIdsInBackground({"t1-a", "t1-b"});
  const LeasedTask lied = MustLease("rogue");
  const LeasedTask other = MustLease("rogue");  // a second lease it holds meanwhile
  ASSERT_TRUE(Report(lied, "rogue", 0.6).ok());
  const LeasedTask check = MustLease("w2");
  ASSERT_EQ(check.spec.id, lied.spec.id);
  ASSERT_TRUE(Report(check, "w2", 0.5).ok());
  EXPECT_EQ(s.Counters().spot_mismatches_total, 1);
  EXPECT_FALSE(Stored(lied.spec.id));
  const LeasedTask decide = MustLease("w3");
  ASSERT_EQ(decide.spec.id, lied.spec.id);
  ASSERT_TRUE(Report(decide, "w3", 0.5).ok());
  std::string why;
  ASSERT_TRUE(s.WorkerQuarantined("rogue", &why));
  EXPECT_NE(why.find("differs from those of workers w2 and w3"), std::string::npos) << why;
  EXPECT_FALSE(s.WorkerQuarantined("w2", nullptr));
  EXPECT_FALSE(Poll("rogue"));
  EXPECT_EQ(Report(other, "rogue", 0.5).code(), Status::Code::kFailedPrecondition);
  // Its other lease went back to the queue; honest workers finish the job.
  const LeasedTask b1 = MustLease("w2");
  ASSERT_EQ(b1.spec.id, other.spec.id);
  ASSERT_TRUE(Report(b1, "w2", 0.25).ok());
  const LeasedTask b2 = MustLease("w3");
  ASSERT_TRUE(Report(b2, "w3", 0.25).ok());
  run_.join();
  ASSERT_TRUE(run_status_.ok()) << run_status_.ToString();
  EXPECT_EQ(results_[0].values[0], 0.5);
  EXPECT_EQ(s.Counters().workers_quarantined_total, 1);
}

// Three different results: no two workers vouch for any, so the task is quarantined
// and its job fails naming them; nobody is singled out.
TEST_F(SpotTest, ThreeDifferentResultsQuarantineTheTask) {
  Scheduler& s = Start({"w1", "w2", "w3"});
  RunIdsInBackground({"t1-a"});
  ASSERT_TRUE(Report(MustLease("w1"), "w1", 0.5).ok());
  ASSERT_TRUE(Report(MustLease("w2"), "w2", 0.6).ok());
  ASSERT_TRUE(Report(MustLease("w3"), "w3", 0.7).ok());
  run_.join();
  EXPECT_EQ(run_status_.code(), Status::Code::kInternal);
  EXPECT_NE(run_status_.message().find("workers w1,w2,w3 returned three different results"), std::string::npos)
      << run_status_.ToString();
  EXPECT_FALSE(Stored("t1-a"));
  EXPECT_EQ(s.Counters().workers_quarantined_total, 0);
}

// One worker: nothing to compare with, so its result is accepted at once.
TEST_F(SpotTest, OneWorkerAloneIsNotCheckedAndItsJobFinishes) {
  Start({"w1"});
  RunIdsInBackground({"t1-a"});
  ASSERT_TRUE(Report(MustLease("w1"), "w1", 0.5).ok());
  run_.join();
  ASSERT_TRUE(run_status_.ok()) << run_status_.ToString();
  EXPECT_TRUE(Stored("t1-a"));
}

// The only other worker falls silent while a result waits for its opinion: the
// check is dropped and the first worker runs the task again, instead of the job
// waiting forever.
TEST_F(SpotTest, AVerifierThatLeavesDoesNotStallTheJob) {
  Scheduler& s = Start({"w1", "w2"});
  RunIdsInBackground({"t1-a"});
  ASSERT_TRUE(Report(MustLease("w1"), "w1", 0.5).ok());
  EXPECT_FALSE(Poll("w1"));
  clock_.Advance(11s);  // w2 not heard from for more than a lease
  s.ReapExpired();
  LeasedTask again;
  ASSERT_TRUE(Poll("w1", &again));
  ASSERT_TRUE(Report(again, "w1", 0.5).ok());
  run_.join();
  ASSERT_TRUE(run_status_.ok()) << run_status_.ToString();
}

// The registry forgets workers silent for worker_forget_leases lease periods; a
// forgotten worker that calls again is registered again.
TEST_F(SpotTest, SilentWorkersLeaveTheRegistry) {
  options_.worker_forget_leases = 3;  // 30 s
  Scheduler& s = Start({"w1", "w2"});
  EXPECT_EQ(s.Workers(), (std::vector<std::string>{"w1", "w2"}));
  EXPECT_EQ(s.ActiveWorkers(), 2);
  clock_.Advance(20s);
  std::vector<std::string> cancelled;
  s.Heartbeat("w2", {}, &cancelled);
  s.ReapExpired();
  EXPECT_EQ(s.Workers().size(), 2u);
  EXPECT_EQ(s.ActiveWorkers(), 1) << "w1 is silent for more than a lease";
  clock_.Advance(15s);  // w1 silent 35 s, w2 15 s
  s.ReapExpired();
  EXPECT_EQ(s.Workers(), std::vector<std::string>{"w2"});
  EXPECT_EQ(s.ActiveWorkers(), 0);
  Poll("w1");
  EXPECT_EQ(s.Workers(), (std::vector<std::string>{"w1", "w2"}));
}

}  // namespace
}  // namespace wormdrag::server
