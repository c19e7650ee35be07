// A scheduler over a real task store with a clock the test moves by hand, for the lease
// and spot-check tests: leases of 10 s, and no reaper thread (the test calls
// ReapExpired() itself).
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "server/scheduler.h"
#include "tests/server/manual_clock.h"

namespace wormdrag::server {

class SchedulerFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = ::testing::TempDir() + "/scheduler_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name() + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db";
    std::remove(path_.c_str());
    auto store = TaskStore::Open(path_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(*store);
    options_.clock = &clock_;
    options_.reaper_thread = false;
    options_.lease_seconds = 10;
  }
  void TearDown() override {
    if (run_.joinable()) {
      if (scheduler_) scheduler_->Stop();
      run_.join();
    }
    scheduler_.reset();
    store_.reset();
    std::remove(path_.c_str());
  }
  // The scheduler with job 1; each of `workers` polls once, so it is registered and live.
  Scheduler& Start(const std::vector<std::string>& workers = {}) {
    scheduler_ = std::make_unique<Scheduler>(store_.get(), options_);
    scheduler_->AddJob(1, JobInfo());
    for (const auto& w : workers) Poll(w);
    return *scheduler_;
  }
  // One lease request that does not wait.
  bool Poll(const std::string& worker, LeasedTask* t = nullptr) {
    LeasedTask ignored;
    return scheduler_->Lease(worker, std::chrono::milliseconds(0), t ? t : &ignored);
  }
  static TaskSpec Task(const std::string& id, int sets = 1) {
    TaskSpec t;
    t.id = id;
    t.job = 1;
    t.sets.assign(sets, Coefficients{0.1, 0.2, 0.001, 0.002});
    return t;
  }
  // Run() of `tasks` in a thread, as a job's evaluator does.
  void RunInBackground(std::vector<TaskSpec> tasks) {
    run_ = std::thread([this, tasks] { run_status_ = scheduler_->Run(1, tasks, &results_, nullptr); });
  }
  // The same with tasks of one set each, by id.
  void RunIdsInBackground(const std::vector<std::string>& ids) {
    std::vector<TaskSpec> tasks;
    for (const auto& id : ids) tasks.push_back(Task(id));
    RunInBackground(std::move(tasks));
  }
  Status Finish() {
    run_.join();
    return run_status_;
  }
  LeasedTask MustLease(const std::string& worker) {
    LeasedTask t;
    EXPECT_TRUE(scheduler_->Lease(worker, std::chrono::milliseconds(5000), &t)) << worker << " got no task";
    return t;
  }
  bool NothingToLease() { return !Poll("idle"); }
  Status ReportValues(const LeasedTask& t, const std::string& worker, std::vector<double> values) {
    TaskResult r;
    r.values = std::move(values);
    bool duplicate = false;
    return scheduler_->Report(worker, t.spec.id, t.lease_id, r, "", &duplicate);
  }
  Status Report(const LeasedTask& t, const std::string& worker, double value) {
    return ReportValues(t, worker, {value});
  }
  bool Stored(const std::string& id) {
    auto g = store_->Get(id);
    return g.ok() && g->has_value();
  }

  ManualClock clock_;
  SchedulerOptions options_;
  std::string path_;
  std::unique_ptr<TaskStore> store_;
  std::unique_ptr<Scheduler> scheduler_;
  std::thread run_;
  Status run_status_;
  std::vector<TaskResult> results_;
};

}  // namespace wormdrag::server
