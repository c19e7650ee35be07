// Faults of the service's own machinery against real processes (docs/reliability.md):
// a poison task that kills every worker that takes it, reports from workers that do
// not hold the task's lease, two coordinators on one file, another process holding
// SQLite's write lock, a damaged database file, a full disk.
#include <fcntl.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"
#include "proto/convert.h"
#include "tests/integration/health.h"
#include "tests/integration/process.h"
#include "tests/integration/service_fixture.h"
#include "tests/integration/small_pair.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace wormdrag {
namespace {

namespace fs = std::filesystem;
namespace v2 = wormdrag::v2;
using itest::FreePort;
using itest::Process;
using namespace std::chrono_literals;

class ReliabilityTest : public itest::ServiceFixture {
 protected:
  void TearDown() override {
    workers_.clear();
    server_.reset();
    if (!mount_.empty()) umount2(mount_.c_str(), MNT_DETACH);
    ServiceFixture::TearDown();
  }

  // A coordinator on `address` over this test's database, not waited for.
  std::unique_ptr<Process> Server(const std::string& address, const std::string& log,
                                  std::vector<std::string> extra = {}) {
    std::vector<std::string> argv = {WORMDRAG_SERVER_BIN, "--listen", address, "--db", db_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<Process>(argv, dir_ + "/" + log);
  }
  // Workers are named w0, w1, … in the order they start.
  Process& StartWorker(const std::map<std::string, std::string>& env = {}) {
    return ServiceFixture::StartWorker("w" + std::to_string(workers_.size()), {}, env);
  }

  // 1 SERVING, 2 NOT_SERVING, -1 no answer (itest::HealthStatus).
  int Health() { return itest::HealthStatus(Channel()); }
  bool Ended(int64_t id) { return Terminal(GetJob(id).state()); }
  v2::Task Lease(const std::string& worker) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 10s);
    v2::LeaseTaskRequest req;
    req.set_worker_id(worker);
    req.set_wait_ms(5000);
    v2::LeaseTaskResponse resp;
    EXPECT_TRUE(v2::WorkerService::NewStub(Channel())->LeaseTask(&ctx, req, &resp).ok());
    EXPECT_TRUE(resp.has_task()) << "no task to lease";
    return resp.task();
  }
  grpc::Status Report(const v2::ReportResultRequest& req) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 10s);
    v2::ReportResultResponse resp;
    return v2::WorkerService::NewStub(Channel())->ReportResult(&ctx, req, &resp);
  }

  std::string mount_;
};

// ------------------------------------------------------------ poison task

// Every worker that leases a task of job 1 aborts (WORMDRAG_TEST_ABORT_ON_TASK). The
// coordinator is killed after two lost leases and restarted: the count survives, the
// third lost lease quarantines the task and the job fails naming it and the three
// workers it killed; the coordinator keeps serving.
TEST_F(ReliabilityTest, PoisonTaskIsQuarantinedAfterKillingThreeWorkersAcrossARestart) {
  const std::vector<std::string> flags = {"--lease-seconds", "1", "--max-lost-leases", "3"};
  StartServer(flags);
  const int64_t id = Submit();
  ASSERT_EQ(id, 1);
  const std::map<std::string, std::string> poison = {{"WORMDRAG_TEST_ABORT_ON_TASK", "t1-"}};
  std::string task;
  for (int i = 0; i < 3; ++i) {
    if (i == 2) {
      // Two leases lost: kill the coordinator, start it again on the same file.
      ASSERT_TRUE(WaitFor([&] { return server_->Log().find("(lost 2 of 3)") != std::string::npos; }, 20s))
          << server_->Log();
      server_->Signal(SIGKILL);
      server_->Wait();
      StartServer(flags, "server2.log");
    }
    Process& w = StartWorker(poison);
    int code = 0;
    ASSERT_TRUE(w.WaitFor(30s, &code)) << w.Log();
    EXPECT_EQ(code, 128 + SIGABRT) << w.Log();
    const std::string log = w.Log();
    const size_t at = log.find("event=test_abort task=");
    ASSERT_NE(at, std::string::npos) << log;
    const std::string this_task = log.substr(at + 22, log.find(' ', at + 22) - at - 22);
    if (i == 0) task = this_task;
    EXPECT_EQ(this_task, task) << "a lost lease sends the task to the front of its queue";
  }
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 30s)) << server_->Log();
  const v2::Job j = GetJob(id);
  EXPECT_EQ(j.state(), v2::JOB_STATE_FAILED);
  EXPECT_NE(j.error().find("task " + task + " was quarantined"), std::string::npos) << j.error();
  EXPECT_NE(j.error().find("lost its lease 3 times"), std::string::npos) << j.error();
  EXPECT_NE(j.error().find("workers w0,w1,w2"), std::string::npos) << j.error();
  EXPECT_NE(server_->Log().find("event=task_attempts_restored task=" + task), std::string::npos) << server_->Log();
  EXPECT_NE(server_->Log().find("event=task_quarantined task=" + task), std::string::npos) << server_->Log();
  EXPECT_EQ(Health(), 1);
  // A healthy worker finds nothing of the failed job to do; the server stays up.
  int code = 0;
  EXPECT_FALSE(server_->WaitFor(200ms, &code)) << server_->Log();
}

// ------------------------------------------------------------ the lease holder

// Reports from a worker without the task's lease are refused (FAILED_PRECONDITION)
// and their errors are not counted (--max-attempts 1 would fail the job at once);
// the holder's values are checked; a real worker then finishes the job.
TEST_F(ReliabilityTest, RogueReportsWithoutTheLeaseAreRefusedAndNotCounted) {
  StartServer({"--lease-seconds", "2", "--max-attempts", "1"});
  const int64_t id = Submit();
  const v2::Task t = Lease("holder");
  ASSERT_FALSE(t.lease_id().empty());
  v2::ReportResultRequest rogue;
  rogue.set_worker_id("rogue");
  rogue.set_task_id(t.task_id());
  rogue.set_error("I say this task fails");
  grpc::Status st = Report(rogue);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << st.error_message();
  EXPECT_NE(st.error_message().find("lease"), std::string::npos) << st.error_message();
  rogue.set_lease_id(t.lease_id() + "0");  // a guess
  EXPECT_EQ(Report(rogue).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  // Values in the holder's report: one per set, finite, non-negative.
  v2::ReportResultRequest bad;
  bad.set_worker_id("holder");
  bad.set_task_id(t.task_id());
  bad.set_lease_id(t.lease_id());
  for (int i = 0; i < t.sets_size(); ++i) bad.add_values(i == 0 ? -1.0 : 0.5);
  EXPECT_EQ(Report(bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  bad.clear_values();
  bad.add_values(0.5);
  if (t.sets_size() != 1) { EXPECT_EQ(Report(bad).error_code(), grpc::StatusCode::INVALID_ARGUMENT); }
  EXPECT_EQ(GetJob(id).state(), v2::JOB_STATE_RUNNING);
  // The held lease runs out (the hand-driven holder never heartbeats); a real worker
  // takes the task and the job completes.
  StartWorker();
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300s)) << server_->Log();
  const v2::Job j = GetJob(id);
  EXPECT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  EXPECT_NE(server_->Log().find("event=report_rejected task=" + t.task_id()), std::string::npos);
  EXPECT_EQ(server_->Log().find("quarantined"), std::string::npos) << server_->Log();
}

// ------------------------------------------------------------ one writer

// A second coordinator on the same file refuses to start, naming the first (pid and
// host); once the first is gone (even by SIGKILL) the file is free again.
TEST_F(ReliabilityTest, SecondCoordinatorOnTheSameFileRefusesNamingTheHolder) {
  StartServer();
  const std::string other = "127.0.0.1:" + std::to_string(FreePort());
  auto second = Server(other, "second.log");
  int code = 0;
  ASSERT_TRUE(second->WaitFor(20s, &code)) << "the second coordinator kept running: " << second->Log();
  EXPECT_EQ(code, 2) << second->Log();
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  const std::string log = second->Log();
  EXPECT_NE(log.find(db_ + " is in use by another coordinator"), std::string::npos) << log;
  EXPECT_NE(log.find("pid " + std::to_string(server_->pid()) + " on host " + host), std::string::npos) << log;
  EXPECT_NE(log.find(db_ + ".lock"), std::string::npos) << log;
  EXPECT_EQ(Health(), 1) << "the first coordinator was disturbed";
  server_->Signal(SIGKILL);
  server_->Wait();
  StartServer({}, "third.log");  // the kernel dropped the dead holder's lock
}

// A second coordinator on a port already in use (another database): gRPC would share
// the port between the two (SO_REUSEPORT) and split the workers and clients between
// them; it refuses to start instead.
TEST_F(ReliabilityTest, SecondCoordinatorOnTheSamePortRefuses) {
  StartServer();
  Process second({WORMDRAG_SERVER_BIN, "--listen", address_, "--db", dir_ + "/other.db"}, dir_ + "/port.log");
  int code = 0;
  ASSERT_TRUE(second.WaitFor(20s, &code)) << "the second coordinator kept running: " << second.Log();
  EXPECT_EQ(code, 2) << second.Log();
  EXPECT_NE(second.Log().find("cannot listen on " + address_), std::string::npos) << second.Log();
  EXPECT_EQ(Health(), 1) << "the first coordinator was disturbed";
}

// Exposure: a coordinator on a non-loopback address with no token refuses to start
// unless told --insecure; a token may come from a file instead of the command line.
TEST_F(ReliabilityTest, OpenListenerNeedsATokenOrInsecure) {
  const std::string open = "0.0.0.0:" + std::to_string(FreePort());
  auto refused = Server(open, "open.log");
  int code = 0;
  ASSERT_TRUE(refused->WaitFor(20s, &code)) << "it kept running: " << refused->Log();
  EXPECT_EQ(code, 2);
  EXPECT_NE(refused->Log().find("with no token"), std::string::npos) << refused->Log();
  EXPECT_NE(refused->Log().find("--insecure"), std::string::npos) << refused->Log();

  const std::string file = dir_ + "/token";
  std::ofstream(file) << "  s3cret\n";
  auto with_file = Server(open, "file.log", {"--token-file", file});
  ASSERT_TRUE(WaitFor([&] { return with_file->Log().find("event=listening") != std::string::npos; }, 20s))
      << with_file->Log();
  EXPECT_NE(with_file->Log().find("auth=true"), std::string::npos) << with_file->Log();
  EXPECT_NE(with_file->Log().find("event=token_without_tls"), std::string::npos) << with_file->Log();
  with_file->Signal(SIGTERM);
  ASSERT_TRUE(with_file->WaitFor(20s, &code));
  EXPECT_EQ(code, 0) << with_file->Log();

  std::ofstream(file, std::ios::trunc) << "\n";
  auto empty = Server(open, "empty.log", {"--token-file", file});
  ASSERT_TRUE(empty->WaitFor(20s, &code));
  EXPECT_EQ(code, 2);
  EXPECT_NE(empty->Log().find("token file " + file + ": empty"), std::string::npos) << empty->Log();
}

// A database whose pages were overwritten: the coordinator refuses to open it, naming
// the file and SQLite's findings, and writes nothing to it.
TEST_F(ReliabilityTest, DamagedDatabaseFileIsRefusedWithAClearError) {
  {
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    bool reused = false;
    auto id = SubmitEstimateJob(**store, Inputs(), SmallOptions(), false, &reused);
    ASSERT_TRUE(id.ok()) << id.status().ToString();
  }  // closed: the WAL is checkpointed into the file
  ASSERT_FALSE(fs::exists(db_ + "-wal"));
  const auto size = fs::file_size(db_);
  ASSERT_GE(size, 8u * 4096) << "expected a database of several pages";
  {
    // Pages 2 and 3 (b-tree pages of the schema's first tables) become noise.
    std::fstream f(db_, std::ios::in | std::ios::out | std::ios::binary);
    std::string noise(2 * 4096, '\0');
    uint32_t x = 12345;
    for (auto& c : noise) c = static_cast<char>((x = x * 1103515245 + 12345) >> 16);
    f.seekp(4096);
    f.write(noise.data(), static_cast<std::streamsize>(noise.size()));
  }
  const auto damaged = fs::last_write_time(db_);
  auto server = Server(address_, "server.log");
  int code = 0;
  ASSERT_TRUE(server->WaitFor(20s, &code)) << "the coordinator opened a damaged file: " << server->Log();
  EXPECT_EQ(code, 2) << server->Log();
  const std::string log = server->Log();
  EXPECT_NE(log.find(db_ + ": the database is damaged"), std::string::npos) << log;
  EXPECT_NE(log.find("restore it from a backup"), std::string::npos) << log;
  EXPECT_EQ(fs::file_size(db_), size);
  EXPECT_EQ(fs::last_write_time(db_), damaged);
}

// ------------------------------------------------------------ storage faults

// Another process holds SQLite's write lock for 3 s while a job runs; the coordinator
// waits --sqlite-busy-ms (100) per try and retries with back-off instead of failing
// the job or a report.
TEST_F(ReliabilityTest, HeldSqliteWriteLockDelaysTheJobButLosesNothing) {
  StartServer({"--sqlite-busy-ms", "100"});
  const int64_t id = Submit();
  Process holder({"/usr/bin/python3", "-c",
                  "import sqlite3, sys, time\n"
                  "c = sqlite3.connect(sys.argv[1], isolation_level=None, timeout=30)\n"
                  "c.execute('BEGIN IMMEDIATE')\n"
                  "print('locked', flush=True)\n"
                  "time.sleep(3)\n"
                  "c.execute('COMMIT')\n"
                  "print('released', flush=True)\n",
                  db_},
                 dir_ + "/holder.log");
  ASSERT_TRUE(WaitFor([&] { return holder.Log().find("locked") != std::string::npos; }, 20s)) << holder.Log();
  StartWorker();
  EXPECT_EQ(holder.Wait(), 0) << holder.Log();
  ASSERT_NE(holder.Log().find("released"), std::string::npos) << holder.Log();
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300s)) << server_->Log();
  const v2::Job j = GetJob(id);
  EXPECT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  EXPECT_NE(server_->Log().find("event=sqlite_busy"), std::string::npos) << server_->Log();
  EXPECT_EQ(workers_[0]->Log().find("event=report_dropped"), std::string::npos) << workers_[0]->Log();
}

// The database on a small tmpfs that is then filled: the coordinator turns NOT_SERVING
// with a clear log line, refuses new submissions, holds the job and its reports, and
// once space returns serves again and finishes the job with no report lost.
TEST_F(ReliabilityTest, FullDiskTurnsNotServingAndResumesWhenSpaceReturns) {
  mount_ = dir_ + "/disk";
  fs::create_directories(mount_);
  if (mount("tmpfs", mount_.c_str(), "tmpfs", 0, "size=16m") != 0) {
    const std::string why = std::strerror(errno);
    mount_.clear();
    GTEST_SKIP() << "cannot mount a tmpfs here (" << why << "; needs CAP_SYS_ADMIN): the full-disk test is skipped";
  }
  db_ = mount_ + "/coordinator.db";
  StartServer({"--lease-seconds", "5"});
  const int64_t id = Submit();
  // Fill the file system to the last byte.
  const std::string filler = mount_ + "/filler";
  {
    const int fd = open(filler.c_str(), O_WRONLY | O_CREAT, 0644);
    ASSERT_GE(fd, 0);
    const std::string chunk(1 << 16, 'x');
    for (size_t n = chunk.size(); n > 0;) {
      const ssize_t w = write(fd, chunk.data(), n);
      if (w < 0) n /= 2;  // ENOSPC: fill what is left in smaller pieces
    }
    close(fd);
  }
  StartWorker();
  ASSERT_TRUE(WaitFor([&] { return Health() == 2; }, 60s)) << "still serving on a full disk: " << server_->Log();
  EXPECT_NE(server_->Log().find("event=storage_full"), std::string::npos) << server_->Log();
  EXPECT_NE(server_->Log().find("event=not_serving reason=\"storage full\""), std::string::npos);
  {
    // A new job cannot be stored: refused, not queued unseen.
    auto in = Inputs();
    v2::SubmitJobRequest req;
    req.mutable_recording1()->set_name("other1.csv");
    req.mutable_recording1()->set_content(in[0].content + "\n");
    req.mutable_recording2()->set_name("other2.csv");
    req.mutable_recording2()->set_content(in[1].content + "\n");
    rpc::OptionsToProto(SmallOptions(), req.mutable_options());
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 30s);
    v2::SubmitJobResponse resp;
    grpc::Status st = v2::JobService::NewStub(Channel())->SubmitJob(&ctx, req, &resp);
    EXPECT_EQ(st.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << st.error_message();
  }
  std::this_thread::sleep_for(2s);
  EXPECT_NE(GetJob(id).state(), v2::JOB_STATE_FAILED) << GetJob(id).error();
  fs::remove(filler);
  ASSERT_TRUE(WaitFor([&] { return Health() == 1; }, 60s)) << server_->Log();
  EXPECT_NE(server_->Log().find("event=storage_recovered"), std::string::npos) << server_->Log();
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300s)) << server_->Log();
  const v2::Job j = GetJob(id);
  EXPECT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  EXPECT_EQ(workers_[0]->Log().find("event=report_dropped"), std::string::npos) << workers_[0]->Log();
}

}  // namespace
}  // namespace wormdrag
