// The scheduler's handling of early abandoning (task results with NaN for abandoned
// sets, and knot counts, through the durable blob and Report's checks) and of residual
// tasks with Jacobians.
#include "server/scheduler.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include <gtest/gtest.h>

#include "core/estimate/paired_path.h"

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
  EXPECT_EQ(leased_cut.spec.keep, 3);  // what the worker service puts on the wire
  EXPECT_EQ(leased_cut.spec.cut, 0.5);
  bool duplicate = false;
  TaskResult abandoned;
  abandoned.values = {kAbandoned};
  abandoned.knots = 40;
  abandoned.knots_full = 300;
  EXPECT_EQ(s.Report("w", "t1-exact", abandoned, "", &duplicate).code(), Status::Code::kInvalidArgument);
  ASSERT_TRUE(s.Report("w", "t1-cut", abandoned, "", &duplicate).ok());
  TaskResult value;
  value.values = {0.25};
  ASSERT_TRUE(s.Report("w", "t1-exact", value, "", &duplicate).ok());
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
  r.residuals = {{0.5, -0.25}, {}};  // the second set cannot be simulated
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7}, {}};  // one value short
  EXPECT_EQ(s.Report("w", "t1-jac", r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, 8}, {1}};  // the empty residual vector has a Jacobian
  EXPECT_EQ(s.Report("w", "t1-jac", r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, NAN}, {}};
  EXPECT_EQ(s.Report("w", "t1-jac", r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{1, 2, 3, 4, 5, 6, 7, 8}, {}};
  ASSERT_TRUE(s.Report("w", "t1-jac", r, "", &duplicate).ok());
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
  EXPECT_EQ(s.Report("w", "t1-res", r, "", &duplicate).code(), Status::Code::kInvalidArgument);
  r.jacobians = {{}};  // what the service fills for a report without Jacobians
  ASSERT_TRUE(s.Report("w", "t1-res", r, "", &duplicate).ok());
  run.join();
  ASSERT_TRUE(run_status.ok()) << run_status.ToString();
  s.Stop();
  (*store)->Close();
  std::remove(path.c_str());
}

}  // namespace
}  // namespace wormdrag::server
