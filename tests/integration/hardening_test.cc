// Workers that lie or stall, and the coordinator's bounds, against real processes
// (docs/reliability.md): a spot-check catches a worker returning plausible but wrong
// values, a worker stopped past the task deadline loses its task to another, later
// jobs wait behind --max-running-jobs, and calls beyond --max-rpc-threads are refused.
#include <signal.h>

#include <atomic>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/integration/service_fixture.h"

namespace wormdrag {
namespace {

using itest::Process;
using namespace std::chrono_literals;
namespace v2 = wormdrag::v2;

class HardeningTest : public itest::ServiceFixture {
 protected:
  bool LogHas(const Process& p, const std::string& what) { return p.Log().find(what) != std::string::npos; }
  // 'T' when the process is stopped (/proc/PID/stat).
  static char ProcessState(pid_t pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t paren = stat.rfind(')');
    return paren == std::string::npos || paren + 2 >= stat.size() ? '?' : stat[paren + 2];
  }
};

// Every task spot-checked; one of three workers multiplies its values by 1 + 1e-6.
// Its first checked result disagrees with an honest worker's, the third worker sides
// with the honest one, the rogue is quarantined (its next lease request is refused and
// it exits 2), none of its values is used, and the job equals an embedded run.
TEST_F(HardeningTest, SpotCheckCatchesAWorkerReturningWrongValues) {
  StartServer({"--spot-check-fraction", "1", "--chunk-sets", "8", "--lease-seconds", "5"});
  StartWorker("w0");
  StartWorker("w1");
  Process& rogue = StartWorker("rogue", {}, {{"WORMDRAG_TEST_WRONG_VALUES", "1e-6"}});
  ASSERT_TRUE(WaitFor(
      [&] {
        for (const auto& w : workers_)
          if (!LogHas(*w, "event=connected")) return false;
        return true;
      },
      20s));
  const int64_t id = Submit();
  const v2::Job j = WaitEnded(id);
  ASSERT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  const std::string log = server_->Log();
  EXPECT_NE(log.find("event=spot_check_mismatch"), std::string::npos) << log;
  EXPECT_NE(log.find("event=worker_quarantined worker=rogue"), std::string::npos) << log;
  EXPECT_EQ(log.find("event=worker_quarantined worker=w"), std::string::npos) << "an honest worker was quarantined";
  int code = 0;
  ASSERT_TRUE(rogue.WaitFor(30s, &code)) << rogue.Log();
  EXPECT_EQ(code, 2) << rogue.Log();
  EXPECT_TRUE(LogHas(rogue, "worker rogue is quarantined")) << rogue.Log();
  ExpectSameAsEmbedded(id);
}

// A worker stops (SIGSTOP: no heartbeats, no progress) on the first task it leases;
// its lease would last 60 s, but the task's deadline (4 s) revokes it, another worker
// runs the task and the job equals an embedded run. Continued, the stopped worker's
// late result is not used and it carries on.
TEST_F(HardeningTest, WorkerStalledPastTheTaskDeadlineLosesItsTask) {
  StartServer(
      {"--task-deadline", "4,0", "--lease-seconds", "60", "--max-lost-leases", "10", "--spot-check-fraction", "0"});
  Process& stalled = StartWorker("stalled", {}, {{"WORMDRAG_TEST_STOP_ON_TASK", "t1-"}});
  ASSERT_TRUE(WaitFor([&] { return LogHas(stalled, "event=connected"); }, 20s)) << stalled.Log();
  const int64_t id = Submit();
  ASSERT_TRUE(WaitFor([&] { return ProcessState(stalled.pid()) == 'T'; }, 30s)) << stalled.Log();
  const std::string log = stalled.Log();
  const size_t at = log.find("event=test_stop task=");
  ASSERT_NE(at, std::string::npos) << log;
  const std::string task = log.substr(at + 21, log.find(' ', at + 21) - at - 21);
  StartWorker("w1");
  const v2::Job j = WaitEnded(id, "", 120s);
  ASSERT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  EXPECT_TRUE(LogHas(*server_, "lease of task " + task + " (job 1) by worker stalled ran past its deadline of 4 s"))
      << server_->Log();
  EXPECT_TRUE(LogHas(*workers_[1], "event=task_reported task=" + task)) << workers_[1]->Log();
  ExpectSameAsEmbedded(id);
  stalled.Signal(SIGCONT);
  EXPECT_TRUE(WaitFor(
      [&] {
        return LogHas(stalled, "event=report_dropped task=" + task) ||
               LogHas(stalled, "event=task_dropped task=" + task);
      },
      30s))
      << stalled.Log();
  stalled.Signal(SIGTERM);
  int code = 0;
  ASSERT_TRUE(stalled.WaitFor(30s, &code)) << stalled.Log();
  EXPECT_EQ(code, 0) << stalled.Log();
}

// --max-running-jobs 1: the second submission stays queued while the first runs (no
// worker yet), then starts when the first is done; both finish.
TEST_F(HardeningTest, JobsBeyondMaxRunningJobsWaitQueuedUntilOneEnds) {
  StartServer({"--max-running-jobs", "1"});
  const int64_t first = Submit("", 3);
  const int64_t second = Submit("", 2);
  ASSERT_TRUE(WaitFor([&] { return GetJob(first).state() == v2::JOB_STATE_RUNNING; }, 20s));
  std::this_thread::sleep_for(1s);
  EXPECT_EQ(GetJob(second).state(), v2::JOB_STATE_QUEUED);
  EXPECT_TRUE(LogHas(*server_, "event=job_waiting job=" + std::to_string(second))) << server_->Log();
  StartWorker("w0");
  EXPECT_EQ(WaitEnded(first).state(), v2::JOB_STATE_DONE);
  EXPECT_EQ(WaitEnded(second).state(), v2::JOB_STATE_DONE);
  const std::string log = server_->Log();
  const size_t done = log.find("event=job_done job=" + std::to_string(first));
  const size_t started = log.find("event=job_started job=" + std::to_string(second));
  ASSERT_NE(done, std::string::npos) << log;
  ASSERT_NE(started, std::string::npos) << log;
  EXPECT_LT(done, started) << log;
  ExpectSameAsEmbedded(first);
}

// --max-rpc-threads 8: of 24 watch streams held open at once, some are refused
// RESOURCE_EXHAUSTED; once they close the coordinator serves as before.
TEST_F(HardeningTest, CallsBeyondTheThreadQuotaAreRefused) {
  StartServer({"--max-rpc-threads", "8"});
  const int64_t id = Submit();
  std::atomic<int> exhausted{0}, opened{0};
  std::vector<std::thread> watchers;
  for (int i = 0; i < 24; ++i)
    watchers.emplace_back([&] {
      auto stub = v2::JobService::NewStub(Channel());
      grpc::ClientContext ctx;
      Prepare(&ctx, "", 4s);
      v2::WatchJobRequest req;
      req.set_job_id(id);
      auto reader = stub->WatchJob(&ctx, req);
      v2::JobProgress p;
      while (reader->Read(&p)) ++opened;
      if (reader->Finish().error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) ++exhausted;
    });
  for (auto& t : watchers) t.join();
  EXPECT_GT(exhausted.load(), 0);
  EXPECT_GT(opened.load(), 0);
  // Watch handlers notice their ended streams within a second and free their threads.
  EXPECT_TRUE(WaitFor([&] { return GetJob(id).state() == v2::JOB_STATE_RUNNING; }, 10s));
  EXPECT_EQ(itest::HealthStatus(Channel()), 1);
}

}  // namespace
}  // namespace wormdrag
