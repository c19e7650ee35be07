// The check of a reported result's form (CheckResult), the scheduler's handling of
// early abandoning (task results with NaN for abandoned sets, and knot counts, through
// the durable blob and Report's checks), of residual
// tasks with Jacobians, and (with a clock moved by hand) of leases, deadlines, lost
// leases, quarantine and the lease a report must hold.
#include "server/scheduler.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "core/estimate/paired_path.h"
#include "tests/server/scheduler_fixture.h"

namespace wormdrag::server {
namespace {

using namespace std::chrono_literals;

TEST(TaskResultBlob, KeepsAbandonedValuesAndKnotCounts) {
  TaskResult r;
  r.values = {0.5, kAbandoned, INFINITY};
  r.knots = 123456789012;
  r.knots_full = 223456789012;
  TaskResult back;
  ASSERT_TRUE(DecodeResult(EncodeResult(r), &back));
  ASSERT_EQ(back.values.size(), 3u);
  EXPECT_EQ(back.values[0], 0.5);
  EXPECT_TRUE(IsAbandoned(back.values[1]));
  EXPECT_EQ(back.values[2], INFINITY);
  EXPECT_EQ(back.knots, r.knots);
  EXPECT_EQ(back.knots_full, r.knots_full);
  // A blob written before knot counts existed: kind 0, u32 count, the doubles.
  std::string old(1, '\0');
  const uint32_t n = 1;
  const double v = 0.25;
  old.append(reinterpret_cast<const char*>(&n), 4).append(reinterpret_cast<const char*>(&v), 8);
  ASSERT_TRUE(DecodeResult(old, &back));
  EXPECT_EQ(back.values, std::vector<double>{0.25});
  EXPECT_EQ(back.knots, 0);
  EXPECT_FALSE(DecodeResult(EncodeResult(r).substr(0, 20), &back));  // truncated
}

// A worker's report is checked against its task's kind before anything is stored.
TEST(CheckResult, RefusesResultsOfTheWrongFormForEachKind) {
  TaskSpec e;
  e.id = "t1";
  e.sets.resize(2);
  TaskResult r;
  r.values = {0.5, INFINITY};  // +inf: a set the solver could not simulate
  EXPECT_TRUE(CheckResult(e, r).ok());
  r.values = {0.5};
  EXPECT_EQ(CheckResult(e, r).code(), Status::Code::kInvalidArgument);
  r.values = {0.5, -1e-300};
  EXPECT_EQ(CheckResult(e, r).code(), Status::Code::kInvalidArgument);
  r.values = {0.5, kAbandoned};
  EXPECT_EQ(CheckResult(e, r).code(), Status::Code::kInvalidArgument) << "no cut was sent";
  e.keep = 10;
  EXPECT_TRUE(CheckResult(e, r).ok());
  e.keep = 0;
  e.set_cuts = {1.0, 1.0};  // group cuts (Phase 3's scale rays) allow it too
  e.set_groups = {0, 0};
  EXPECT_TRUE(CheckResult(e, r).ok());
  e.set_cuts.clear();
  e.set_groups.clear();
  e.keep = 10;
  // A worm's share must say so: a worker that ignores Task.worm answers for both.
  e.worm = 2;
  EXPECT_EQ(CheckResult(e, r).code(), Status::Code::kInvalidArgument);
  r.worm = 2;
  EXPECT_TRUE(CheckResult(e, r).ok());
  e.worm = r.worm = 0;

  TaskSpec fit;
  fit.id = "t2";
  fit.kind = TaskKind::kDiagnoseFit;
  TaskResult f;
  f.values = {1, 2, 3, 4, 5};
  EXPECT_EQ(CheckResult(fit, f).code(), Status::Code::kInvalidArgument);
  f.values.push_back(6);
  EXPECT_TRUE(CheckResult(fit, f).ok());
  f.values[2] = NAN;
  EXPECT_EQ(CheckResult(fit, f).code(), Status::Code::kInvalidArgument);

  TaskSpec refit;
  refit.id = "t3";
  refit.kind = TaskKind::kBootstrapReplicate;
  TaskResult b;
  b.values = {1, 0.6, 0.2, 0.001, 0.0004, 0.01};  // refitted, μ_n, μ_t, η_n, η_t, E
  EXPECT_TRUE(CheckResult(refit, b).ok());
  b.values[1] = -0.2;
  const Status negative = CheckResult(refit, b);
  EXPECT_EQ(negative.code(), Status::Code::kInvalidArgument);
  EXPECT_NE(negative.ToString().find("t3"), std::string::npos) << negative.ToString();
  b.values.pop_back();
  EXPECT_EQ(CheckResult(refit, b).code(), Status::Code::kInvalidArgument);
}

TEST(Scheduler, AcceptsAbandonedValuesOnlyFromTasksThatCarriedACut) {
  const std::string path = ::testing::TempDir() + "/scheduler_test_" + std::to_string(::getpid()) + ".db";
  std::remove(path.c_str());
  auto store = TaskStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  Scheduler s(store->get(), SchedulerOptions());
  s.AddJob(1, JobInfo());
  TaskSpec exact;
  exact.id = "t1-exact";
  exact.job = 1;
  exact.sets = {{0.1, 0.2, 0.001, 0.002}};
  TaskSpec with_cut = exact;
  with_cut.id = "t1-cut";
  with_cut.keep = 3;
  with_cut.cut = 0.5;
  std::vector<TaskResult> results;
  Status run_status;
  std::thread run([&] { run_status = s.Run(1, {exact, with_cut}, &results, nullptr); });
  LeasedTask a, b;
  ASSERT_TRUE(s.Lease("w", 5000ms, &a));
  ASSERT_TRUE(s.Lease("w", 5000ms, &b));
  const LeasedTask& leased_cut = a.spec.id == "t1-cut" ? a : b;
  const LeasedTask& leased_exact = a.spec.id == "t1-cut" ? b : a;
  EXPECT_EQ(leased_cut.spec.keep, 3);  // what the worker service puts on the wire
  EXPECT_EQ(leased_cut.spec.cut, 0.5);
  bool duplicate = false;
  TaskResult abandoned;
  abandoned.values = {kAbandoned};
  abandoned.knots = 40;
  abandoned.knots_full = 300;
  EXPECT_EQ(s.Report("w", "t1-exact", leased_exact.lease_id, abandoned, "", &duplicate).code(),
            Status::Code::kInvalidArgument);
  ASSERT_TRUE(s.Report("w", "t1-cut", leased_cut.lease_id, abandoned, "", &duplicate).ok());
  TaskResult value;
  value.values = {0.25};
  ASSERT_TRUE(s.Report("w", "t1-exact", leased_exact.lease_id, value, "", &duplicate).ok());
  run.join();
  ASSERT_TRUE(run_status.ok()) << run_status.ToString();
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0].values, std::vector<double>{0.25});
  EXPECT_TRUE(IsAbandoned(results[1].values[0]));
  EXPECT_EQ(results[1].knots, 40);
  // Durable as reported: a restarted coordinator finds the same.
  auto stored = (*store)->Get("t1-cut");
  ASSERT_TRUE(stored.ok() && stored->has_value());
  TaskResult back;
  ASSERT_TRUE(DecodeResult(**stored, &back));
  EXPECT_TRUE(IsAbandoned(back.values[0]));
  EXPECT_EQ(back.knots_full, 300);
  s.Stop();
  (*store)->Close();
  std::remove(path.c_str());
}

// A Jacobian task's result holds 4 columns per residual vector, finite, and is not
// written to the store (as residuals are not).
TEST(Scheduler, ChecksResidualJacobiansAndKeepsThemInMemoryOnly) {
  const std::string path = ::testing::TempDir() + "/scheduler_jac_" + std::to_string(::getpid()) + ".db";
  std::remove(path.c_str());
  auto store = TaskStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  Scheduler s(store->get(), SchedulerOptions());
  s.AddJob(1, JobInfo());
  TaskSpec t;
  t.id = "t1-jac";
  t.job = 1;
  t.kind = TaskKind::kResidualJacobians;
  t.sets = {{0.1, 0.2, 0.001, 0.002}, {0, 0, 0, 0}};
  std::vector<TaskResult> results;
  Status run_status;
  std::thread run([&] { run_status = s.Run(1, {t}, &results, nullptr); });
  LeasedTask leased;
  ASSERT_TRUE(s.Lease("w", 5000ms, &leased));
  EXPECT_EQ(leased.spec.kind, TaskKind::kResidualJacobians);
  bool duplicate = false;
  TaskResult r;
  r.residuals = {{0.5, -0.25}, {}};           // the second set cannot be simulated
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7}, {}};  // one value short
  EXPECT_EQ(s.Report("w", "t1-jac", leased.lease_id, r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, 8}, {1}};  // the empty residual vector has a Jacobian
  EXPECT_EQ(s.Report("w", "t1-jac", leased.lease_id, r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, NAN}, {}};
  EXPECT_EQ(s.Report("w", "t1-jac", leased.lease_id, r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, 8}, {}};
  ASSERT_TRUE(s.Report("w", "t1-jac", leased.lease_id, r, "", &duplicate).ok());
  run.join();
  ASSERT_TRUE(run_status.ok()) << run_status.ToString();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].residuals, r.residuals);
  EXPECT_EQ(results[0].jacobians, r.jacobians);
  EXPECT_FALSE(IsDurable(TaskKind::kResidualJacobians));
  auto stored = (*store)->Get("t1-jac");
  ASSERT_TRUE(stored.ok());
  EXPECT_FALSE(stored->has_value());
  s.Stop();
  (*store)->Close();
  std::remove(path.c_str());
}

// A residual task (the finite-difference path) must not carry Jacobians.
TEST(Scheduler, ResidualTaskWithAJacobianIsRejected) {
  const std::string path = ::testing::TempDir() + "/scheduler_res_" + std::to_string(::getpid()) + ".db";
  std::remove(path.c_str());
  auto store = TaskStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  Scheduler s(store->get(), SchedulerOptions());
  s.AddJob(1, JobInfo());
  TaskSpec t;
  t.id = "t1-res";
  t.job = 1;
  t.kind = TaskKind::kResiduals;
  t.sets = {{0.1, 0.2, 0.001, 0.002}};
  std::vector<TaskResult> results;
  Status run_status;
  std::thread run([&] { run_status = s.Run(1, {t}, &results, nullptr); });
  LeasedTask leased;
  ASSERT_TRUE(s.Lease("w", 5000ms, &leased));
  bool duplicate = false;
  TaskResult r;
  r.residuals = {{0.5}};
  r.jacobians = {{1, 2, 3, 4}};
  EXPECT_EQ(s.Report("w", "t1-res", leased.lease_id, r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{}};  // what the service fills for a report without Jacobians
  ASSERT_TRUE(s.Report("w", "t1-res", leased.lease_id, r, "", &duplicate).ok());
  run.join();
  ASSERT_TRUE(run_status.ok()) << run_status.ToString();
  s.Stop();
  (*store)->Close();
  std::remove(path.c_str());
}

// ------------------------------------------------- leases with a hand-moved clock

class LeaseTest : public SchedulerFixture {};

TEST_F(LeaseTest, ALeaseExpiresOnlyWhenTheClockPassesItAndHeartbeatsRenewIt) {
  Scheduler& s = Start();
  RunInBackground({Task("t1-a")});
  const LeasedTask first = MustLease("w1");
  clock_.Advance(9s);
  s.ReapExpired();
  EXPECT_EQ(s.Counters().leased, 1);
  std::vector<std::string> cancelled;
  s.Heartbeat("w1", {"t1-a"}, &cancelled);  // renews to 19 s
  EXPECT_TRUE(cancelled.empty());
  clock_.Advance(9s);
  s.ReapExpired();
  EXPECT_EQ(s.Counters().leased, 1) << "a heartbeat did not renew the lease";
  clock_.Advance(2s);  // 20 s: one past the renewed expiry
  s.ReapExpired();
  EXPECT_EQ(s.Counters().leased, 0);
  EXPECT_EQ(s.Counters().queued, 1);
  EXPECT_EQ(s.Counters().expired_total, 1);
  // The worker that lost it is told to stop, and its late result is refused.
  s.Heartbeat("w1", {"t1-a"}, &cancelled);
  EXPECT_EQ(cancelled, std::vector<std::string>{"t1-a"});
  const LeasedTask second = MustLease("w2");
  EXPECT_EQ(second.spec.id, "t1-a");
  EXPECT_NE(second.lease_id, first.lease_id);
  EXPECT_EQ(ReportValues(first, "w1", {0.5}).code(), Status::Code::kFailedPrecondition);
  ASSERT_TRUE(ReportValues(second, "w2", {0.25}).ok());
  ASSERT_TRUE(Finish().ok()) << run_status_.ToString();
  EXPECT_EQ(results_[0].values, std::vector<double>{0.25});
  EXPECT_EQ(s.rejected_reports(), 1);
}

TEST_F(LeaseTest, TheDeadlineRevokesALeaseThatHeartbeatsKeepAlive) {
  options_.deadline_seconds = 60;
  options_.deadline_seconds_per_set = 1;
  Scheduler& s = Start();
  EXPECT_EQ(DeadlineFor(Task("x", 4), options_), 64);
  RunInBackground({Task("t1-slow", 4)});
  const LeasedTask t = MustLease("w1");
  std::vector<std::string> cancelled;
  for (int i = 0; i < 12; ++i) {  // 60 s of heartbeats every 5 s: within the deadline
    clock_.Advance(5s);
    s.Heartbeat("w1", {"t1-slow"}, &cancelled);
    s.ReapExpired();
  }
  EXPECT_TRUE(cancelled.empty());
  EXPECT_EQ(s.Counters().leased, 1);
  clock_.Advance(5s);  // 65 s > 64 s
  s.Heartbeat("w1", {"t1-slow"}, &cancelled);
  s.ReapExpired();
  EXPECT_EQ(s.Counters().leased, 0);
  EXPECT_EQ(s.Counters().queued, 1);
  s.Heartbeat("w1", {"t1-slow"}, &cancelled);
  EXPECT_EQ(cancelled, std::vector<std::string>{"t1-slow"});
  // A new lease has a new deadline.
  const LeasedTask again = MustLease("w2");
  clock_.Advance(30s);
  s.Heartbeat("w2", {"t1-slow"}, &cancelled);
  s.ReapExpired();
  EXPECT_EQ(s.Counters().leased, 1);
  ASSERT_TRUE(ReportValues(again, "w2", {1, 2, 3, 4}).ok());
  ASSERT_TRUE(Finish().ok()) << run_status_.ToString();
}

TEST_F(LeaseTest, ATaskThatLosesEveryLeaseIsQuarantinedNamingTheWorkersItKilled) {
  options_.max_lost_leases = 3;
  options_.max_attempts = 1;  // lost leases are counted on their own
  Scheduler& s = Start();
  RunInBackground({Task("t1-poison"), Task("t1-fine")});
  for (const char* w : {"w1", "w2", "w3"}) {
    LeasedTask t = MustLease(w);
    if (t.spec.id == "t1-fine") {
      ASSERT_TRUE(ReportValues(t, w, {0.5}).ok());
      t = MustLease(w);
    }
    ASSERT_EQ(t.spec.id, "t1-poison");
    clock_.Advance(11s);  // the worker died: no heartbeat
    s.ReapExpired();
  }
  const Status st = Finish();
  ASSERT_EQ(st.code(), Status::Code::kInternal) << st.ToString();
  EXPECT_NE(st.message().find("task t1-poison was quarantined"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("lost its lease 3 times"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("w1,w2,w3"), std::string::npos) << st.message();
  EXPECT_TRUE(NothingToLease());
  const auto q = s.Quarantined();
  ASSERT_EQ(q.size(), 1u);
  EXPECT_EQ(q[0].task_id, "t1-poison");
  EXPECT_EQ(q[0].worker, "w1,w2,w3");
  EXPECT_EQ(s.Counters().quarantined_total, 1);
}

TEST_F(LeaseTest, LostLeasesAreCountedAcrossACoordinatorRestart) {
  options_.max_lost_leases = 3;
  Start();
  RunInBackground({Task("t1-poison")});
  for (const char* w : {"w1", "w2"}) {
    MustLease(w);
    clock_.Advance(11s);
    scheduler_->ReapExpired();
  }
  auto stored = store_->GetAttempts("t1-poison");
  ASSERT_TRUE(stored.ok() && stored->has_value());
  EXPECT_EQ((*stored)->lost, 2);
  EXPECT_EQ((*stored)->workers, "w1,w2");
  // The coordinator stops (its Run ends UNAVAILABLE) and a new one starts on the file.
  scheduler_->Stop();
  EXPECT_EQ(Finish().code(), Status::Code::kUnavailable);
  Scheduler& s = Start();
  RunInBackground({Task("t1-poison")});
  MustLease("w3");
  clock_.Advance(11s);
  s.ReapExpired();
  const Status st = Finish();
  ASSERT_EQ(st.code(), Status::Code::kInternal) << st.ToString();
  EXPECT_NE(st.message().find("w1,w2,w3"), std::string::npos) << st.message();
  // A job's attempts go with its results.
  ASSERT_TRUE(store_->DeleteJob(1).ok());
  EXPECT_FALSE(store_->GetAttempts("t1-poison")->has_value());
}

TEST_F(LeaseTest, OnlyTheLeaseHolderMayReportAndRogueErrorsAreNotCounted) {
  options_.max_attempts = 1;  // one counted error would quarantine the task
  Scheduler& s = Start();
  RunInBackground({Task("t1-a", 2)});
  const LeasedTask t = MustLease("w1");
  bool duplicate = false;
  TaskResult none;
  // Errors from a worker without the lease, or with a made-up one: refused, not counted.
  EXPECT_EQ(s.Report("rogue", "t1-a", "", none, "boom", &duplicate).code(), Status::Code::kFailedPrecondition);
  EXPECT_EQ(s.Report("rogue", "t1-a", "l42-1", none, "boom", &duplicate).code(), Status::Code::kFailedPrecondition);
  EXPECT_EQ(s.Counters().quarantined_total, 0);
  EXPECT_EQ(s.Counters().leased, 1);
  // Values are checked: one per set, finite (or +inf: cannot be simulated), >= 0.
  EXPECT_EQ(ReportValues(t, "w1", {0.5}).code(), Status::Code::kInvalidArgument);
  EXPECT_EQ(ReportValues(t, "w1", {0.5, -1}).code(), Status::Code::kInvalidArgument);
  EXPECT_EQ(ReportValues(t, "w1", {0.5, NAN}).code(), Status::Code::kInvalidArgument);
  EXPECT_EQ(ReportValues(t, "w1", {0.5, -INFINITY}).code(), Status::Code::kInvalidArgument);
  ASSERT_TRUE(ReportValues(t, "w1", {0.5, 0.75}).ok());
  ASSERT_TRUE(Finish().ok()) << run_status_.ToString();
  // A task already done answers any report as a duplicate, lease or not.
  EXPECT_TRUE(ReportValues(t, "w1", {0.5, 0.75}).ok());
  EXPECT_EQ(s.rejected_reports(), 2);
}

TEST_F(LeaseTest, TheHoldersErrorsCountAndQuarantineTheTask) {
  options_.max_attempts = 2;
  Scheduler& s = Start();
  RunInBackground({Task("t1-bad")});
  bool duplicate = false;
  for (const char* w : {"w1", "w2"}) {
    const LeasedTask t = MustLease(w);
    ASSERT_TRUE(s.Report(w, t.spec.id, t.lease_id, TaskResult(), "cannot simulate", &duplicate).ok());
  }
  const Status st = Finish();
  ASSERT_EQ(st.code(), Status::Code::kInternal);
  EXPECT_NE(st.message().find("failed 2 times"), std::string::npos) << st.message();
  EXPECT_EQ((*store_->GetAttempts("t1-bad"))->failures, 2);
}

}  // namespace
}  // namespace wormdrag::server
