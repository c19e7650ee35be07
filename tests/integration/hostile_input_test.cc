// Hostile inputs against real processes: the crash-loop recording (a legal CSV whose
// '# fps: 0.001' implies billions of solver knots) submitted to a real wormdrag-server
// and left in its store for a restart, and the CLI on that CSV and on importer inputs
// that crash a parser without checks. No process may abort; the coordinator keeps serving.
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"
#include "proto/convert.h"
#include "tests/core/jobs/hostile_inputs.h"
#include "tests/integration/process.h"
#include "wormdrag/v2/jobs.grpc.pb.h"

namespace wormdrag {
namespace {

using namespace std::chrono_literals;
using itest::Process;
namespace fs = std::filesystem;

using hostile::SlowFpsRecording;
JobOptions Options() {
  return hostile::SmallOptions();
}

// Peak resident set allowed to a process that refuses the 10 MB time-only recording.
constexpr long kPeakLimitKb = 150 * 1024;

class HostileProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/wormdrag-hostile-XXXXXX";
    dir_ = mkdtemp(tmpl);
    address_ = "127.0.0.1:" + std::to_string(itest::FreePort());
    db_ = dir_ + "/coordinator.db";
    inputs_ = {JobInput{"slow.csv", SlowFpsRecording(1)}, JobInput{"L2.csv", SlowFpsRecording(2)}};
  }
  void TearDown() override {
    server_.reset();
    if (!HasFailure())
      fs::remove_all(dir_);
    else
      std::fprintf(stderr, "logs kept in %s\n", dir_.c_str());
  }
  void StartServer(const std::string& log) {
    server_ = std::make_unique<Process>(
        std::vector<std::string>{WORMDRAG_SERVER_BIN, "--listen", address_, "--db", db_}, dir_ + "/" + log);
  }
  std::unique_ptr<v2::JobService::Stub> Jobs() {
    return v2::JobService::NewStub(grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
  }
  // GetJob until the job is in `state` (the server answering at all is the point).
  bool WaitState(int64_t id, v2::JobState state, v2::Job* out) {
    for (int i = 0; i < 600; ++i) {
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + 1s);
      v2::GetJobRequest req;
      req.set_job_id(id);
      if (Jobs()->GetJob(&ctx, req, out).ok() && out->state() == state) return true;
      int code = 0;
      if (server_->WaitFor(50ms, &code)) {
        ADD_FAILURE() << "the server exited with " << code << ":\n" << server_->Log();
        return false;
      }
    }
    return false;
  }
  std::string Write(const std::string& name, const std::string& content) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  // `peak_kb`, if given, receives the command's peak resident set.
  int RunCli(const std::vector<std::string>& args, std::string* log, long* peak_kb = nullptr) {
    std::vector<std::string> argv = {WORMDRAG_CLI_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    const std::string path = dir_ + "/cli" + std::to_string(cli_runs_++) + ".log";
    Process p(argv, path);
    const int code = p.Wait();
    *log = p.Log();
    if (peak_kb) *peak_kb = p.peak_rss_kb();
    return code;
  }

  std::string dir_, address_, db_;
  std::array<JobInput, 2> inputs_;
  std::unique_ptr<Process> server_;
  int cli_runs_ = 0;
};

TEST_F(HostileProcessTest, CrashLoopCsvIsRefusedOrFailedAndTheServerSurvivesRestarts) {
  // A job stored by a coordinator that does not check the work: a start that resumed
  // it without the check would abort.
  int64_t stored_id = 0;
  {
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    JobRecord job;
    job.kind = "estimate";
    const auto ds = DatasetRecords(inputs_, &job);
    job.options_json = Options().ToJson();
    job.eval_key = EvalKey(job.dataset_hashes, Options());
    auto id = (*store)->CreateJob(job, ds);
    ASSERT_TRUE(id.ok()) << id.status().ToString();
    stored_id = *id;
  }
  StartServer("server1.log");
  v2::Job j;
  ASSERT_TRUE(WaitState(stored_id, v2::JOB_STATE_FAILED, &j)) << server_->Log();
  EXPECT_NE(j.error().find("slow.csv: fps 0.001"), std::string::npos) << j.error();

  // The same recording submitted now is refused, naming the file and field; nothing stored.
  v2::SubmitJobRequest req;
  req.mutable_recording1()->set_name(inputs_[0].name);
  req.mutable_recording1()->set_content(inputs_[0].content);
  req.mutable_recording2()->set_name(inputs_[1].name);
  req.mutable_recording2()->set_content(inputs_[1].content);
  rpc::OptionsToProto(Options(), req.mutable_options());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + 30s);
  v2::SubmitJobResponse resp;
  const grpc::Status st = Jobs()->SubmitJob(&ctx, req, &resp);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("slow.csv: fps 0.001"), std::string::npos) << st.error_message();
  EXPECT_NE(st.error_message().find("'# fps'"), std::string::npos) << st.error_message();

  // Restarted (killed, as a crash would), the coordinator serves and does not resume it.
  server_->Signal(SIGKILL);
  server_->Wait();
  StartServer("server2.log");
  ASSERT_TRUE(WaitState(stored_id, v2::JOB_STATE_FAILED, &j)) << server_->Log();
  std::this_thread::sleep_for(500ms);
  int code = 0;
  EXPECT_FALSE(server_->WaitFor(10ms, &code)) << "exited with " << code << ":\n" << server_->Log();
  EXPECT_EQ(server_->Log().find("event=job_resumed job=" + std::to_string(stored_id)), std::string::npos)
      << server_->Log();
  auto store = JobStore::Open(db_);
  ASSERT_TRUE(store.ok());
  auto jobs = (*store)->ListJobs();
  ASSERT_TRUE(jobs.ok());
  EXPECT_EQ(jobs->size(), 1u);
}

TEST_F(HostileProcessTest, LocalCommandsExit2NamingFileAndField) {
  std::string log;
  const std::string slow = Write("slow.csv", inputs_[0].content), l2 = Write("L2.csv", inputs_[1].content);
  EXPECT_EQ(RunCli({"estimate", slow, l2, "--t-max", "1", "--db", dir_ + "/e.db"}, &log), 2) << log;
  EXPECT_NE(log.find("slow.csv: fps 0.001"), std::string::npos) << log;

  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999999999999, 3), }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string npy = std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(h.size()) + '\0' + h +
                    std::string(48, '\0');
  const std::string huge = Write("huge.npy", npy);
  EXPECT_EQ(RunCli({"import", huge, "--out", dir_ + "/o.csv", "--fps", "30"}, &log), 2) << log;
  EXPECT_NE(log.find("huge.npy: 'shape'"), std::string::npos) << log;

  const std::string wcon = Write("x.wcon", R"({"units":{"t":"s","x":"mm","y":"mm"},
      "data":[{"id":"1","t":[0,1],"x":5,"y":[[1,2,3],[1,2,3]]}]})");
  EXPECT_EQ(RunCli({"import", wcon, "--out", dir_ + "/o.csv"}, &log), 2) << log;
  EXPECT_NE(log.find("x.wcon: data[0].x"), std::string::npos) << log;
}

// 10 MB of time-only rows (every frame missing, ~1.3 million rows): `wormdrag estimate`
// and a submission to a real server refuse it at the first row past t_max, naming the
// file, line and column, holding little more than the file. Reading every row as a
// ~250-byte frame, the CLI peaked at ~540 MB before it refused the file.
TEST_F(HostileProcessTest, TimeOnlyRowsAreRefusedEarlyInMemoryBoundedByTheFile) {
  const std::string content = hostile::TimeOnlyRecording(10 << 20);
  const std::string empty = Write("empty.csv", content), l2 = Write("L2.csv", inputs_[1].content);
  const std::string where = "empty.csv:104: column 2 (x0): no row within 1 s of the first (t = 0) has points";
  std::string log;
  long peak_kb = 0;
  EXPECT_EQ(RunCli({"estimate", empty, l2, "--t-max", "1", "--db", dir_ + "/e.db"}, &log, &peak_kb), 2) << log;
  EXPECT_NE(log.find(where), std::string::npos) << log;
  EXPECT_LT(peak_kb, kPeakLimitKb) << "wormdrag estimate";

  StartServer("server.log");
  v2::SubmitJobRequest req;
  req.mutable_recording1()->set_name("empty.csv");
  req.mutable_recording1()->set_content(content);
  req.mutable_recording2()->set_name(inputs_[1].name);
  req.mutable_recording2()->set_content(inputs_[1].content);
  rpc::OptionsToProto(Options(), req.mutable_options());
  grpc::Status st;
  for (int attempt = 0; attempt < 200; ++attempt) {  // until the server listens
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 30s);
    v2::SubmitJobResponse resp;
    st = Jobs()->SubmitJob(&ctx, req, &resp);
    if (st.error_code() != grpc::StatusCode::UNAVAILABLE) break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << st.error_message();
  EXPECT_NE(st.error_message().find(where), std::string::npos) << st.error_message();
  EXPECT_LT(itest::PeakRssKb(server_->pid()), kPeakLimitKb) << "wormdrag-server";
  auto store = JobStore::Open(db_);
  ASSERT_TRUE(store.ok());
  EXPECT_TRUE((*store)->ListJobs()->empty()) << "the refused job was stored";
}

}  // namespace
}  // namespace wormdrag
