// Credentials against a real wormdrag-server (docs/reliability.md): a worker token
// distinct from the client token works for one service only, and the CLI takes its
// token from a file or the environment instead of the command line.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/integration/service_fixture.h"

namespace wormdrag {
namespace {

using itest::Process;
using namespace std::chrono_literals;
namespace v2 = wormdrag::v2;

class CredentialsTest : public itest::ServiceFixture {
 protected:
  // A server with client token "client-secret" and worker token "worker-secret",
  // both read from files.
  void StartWithTwoTokens(std::vector<std::string> extra = {}) {
    std::ofstream(dir_ + "/client.token") << "client-secret\n";
    std::ofstream(dir_ + "/worker.token") << "worker-secret\n";
    std::vector<std::string> argv = {"--token-file", dir_ + "/client.token", "--worker-token-file",
                                     dir_ + "/worker.token"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    StartServer(argv);
  }
  // The status code of one unary call made with `token`.
  template <typename Call>
  grpc::StatusCode Code(const std::string& token, Call call) {
    grpc::ClientContext ctx;
    Prepare(&ctx, token);
    return call(&ctx).error_code();
  }
  // Every JobService call with `token`; their status codes.
  std::vector<grpc::StatusCode> JobCalls(const std::string& token) {
    auto stub = v2::JobService::NewStub(Channel());
    std::vector<grpc::StatusCode> codes;
    int64_t id = 0;
    codes.push_back(TrySubmit(token, &id).error_code());
    v2::GetJobRequest get;
    get.set_job_id(1);
    v2::CancelJobRequest cancel;
    cancel.set_job_id(1);
    v2::GetResultsRequest results;
    results.set_job_id(1);
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::Job r;
      return stub->GetJob(c, get, &r);
    }));
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::ListJobsResponse r;
      return stub->ListJobs(c, v2::ListJobsRequest(), &r);
    }));
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::CancelJobResponse r;
      return stub->CancelJob(c, cancel, &r);
    }));
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::GetResultsResponse r;
      return stub->GetResults(c, results, &r);
    }));
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::WatchJobRequest req;
      req.set_job_id(1);
      auto reader = stub->WatchJob(c, req);
      v2::JobProgress p;
      if (reader->Read(&p)) c->TryCancel();  // let through: stop the stream
      const grpc::Status st = reader->Finish();
      return st.error_code() == grpc::StatusCode::CANCELLED ? grpc::Status::OK : st;
    }));
    codes.push_back(Code(token, [&](grpc::ClientContext* c) {
      v2::ExportResultsRequest req;
      req.set_job_id(1);
      auto reader = stub->ExportResults(c, req);
      v2::ExportChunk chunk;
      while (reader->Read(&chunk)) {}
      return reader->Finish();
    }));
    return codes;
  }
  // Every WorkerService call with `token`; their status codes.
  std::vector<grpc::StatusCode> WorkerCalls(const std::string& token) {
    auto stub = v2::WorkerService::NewStub(Channel());
    v2::LeaseTaskRequest lease;
    lease.set_worker_id("intruder");
    v2::HeartbeatRequest heartbeat;
    heartbeat.set_worker_id("intruder");
    v2::ReportResultRequest report;
    report.set_worker_id("intruder");
    report.set_task_id("t1-0");
    v2::GetDatasetRequest dataset;
    dataset.set_hash(std::string(64, 'a'));
    return {Code(token,
                 [&](grpc::ClientContext* c) {
                   v2::LeaseTaskResponse r;
                   return stub->LeaseTask(c, lease, &r);
                 }),
            Code(token,
                 [&](grpc::ClientContext* c) {
                   v2::HeartbeatResponse r;
                   return stub->Heartbeat(c, heartbeat, &r);
                 }),
            Code(token,
                 [&](grpc::ClientContext* c) {
                   v2::ReportResultResponse r;
                   return stub->ReportResult(c, report, &r);
                 }),
            Code(token, [&](grpc::ClientContext* c) {
              v2::GetDatasetResponse r;
              return stub->GetDataset(c, dataset, &r);
            })};
  }
  // Runs the CLI; its exit code, its output in *out.
  int Cli(const std::vector<std::string>& args, const std::map<std::string, std::string>& env, std::string* out) {
    std::vector<std::string> argv = {WORMDRAG_CLI_BIN};
    argv.insert(argv.end(), args.begin(), args.end());
    static int n = 0;
    Process p(argv, dir_ + "/cli" + std::to_string(++n) + ".log", env);
    const int code = p.Wait();
    *out = p.Log();
    return code;
  }
};

// With distinct tokens each service accepts its own only: the worker token is refused
// PERMISSION_DENIED by every client call, the client token by every worker call (a
// worker process given it exits 2), and a worker with its token finishes a job the
// client submitted with the client token.
TEST_F(CredentialsTest, WorkerAndClientTokensAreNotInterchangeable) {
  StartWithTwoTokens();
  for (grpc::StatusCode c : JobCalls("worker-secret")) EXPECT_EQ(c, grpc::StatusCode::PERMISSION_DENIED);
  for (grpc::StatusCode c : WorkerCalls("client-secret")) EXPECT_EQ(c, grpc::StatusCode::PERMISSION_DENIED);
  for (grpc::StatusCode c : JobCalls("")) EXPECT_EQ(c, grpc::StatusCode::UNAUTHENTICATED);
  for (grpc::StatusCode c : WorkerCalls("")) EXPECT_EQ(c, grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(GetJob(1, "client-secret").id(), 0) << "no job was stored by the refused submission";

  std::ofstream(dir_ + "/wrong.token") << "client-secret\n";
  Process& intruder = StartWorker("intruder", {"--token-file", dir_ + "/wrong.token"});
  int code = 0;
  ASSERT_TRUE(intruder.WaitFor(20s, &code)) << intruder.Log();
  EXPECT_EQ(code, 2) << intruder.Log();
  EXPECT_NE(intruder.Log().find("event=rejected"), std::string::npos) << intruder.Log();
  EXPECT_NE(intruder.Log().find("client token is not accepted by WorkerService"), std::string::npos) << intruder.Log();

  const int64_t id = Submit("client-secret");
  StartWorker("w0", {"--token-file", dir_ + "/worker.token"});
  const v2::Job j = WaitEnded(id, "client-secret");
  EXPECT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
}

// An open client service (no client token) with a worker token still refuses the
// worker token on client calls: whoever holds it is a worker, not a client.
TEST_F(CredentialsTest, WorkerTokenIsRefusedEvenByAnOpenClientService) {
  std::ofstream(dir_ + "/worker.token") << "worker-secret\n";
  StartServer({"--worker-token-file", dir_ + "/worker.token"});
  for (grpc::StatusCode c : JobCalls("worker-secret")) EXPECT_EQ(c, grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(JobCalls("")[2], grpc::StatusCode::OK);  // ListJobs
  for (grpc::StatusCode c : WorkerCalls("")) EXPECT_EQ(c, grpc::StatusCode::UNAUTHENTICATED);
}

// The CLI's remote commands take the token from --token-file or $WORMDRAG_TOKEN, so
// it never has to appear on a command line; a bad file is refused naming it (exit 2).
TEST_F(CredentialsTest, CliTakesItsTokenFromAFileOrTheEnvironment) {
  StartWithTwoTokens();
  const int64_t id = Submit("client-secret");
  std::string out;
  EXPECT_NE(Cli({"jobs", "list", "--server", address_}, {}, &out), 0) << out;
  EXPECT_NE(out.find("requires a token"), std::string::npos) << out;

  EXPECT_EQ(Cli({"jobs", "list", "--server", address_, "--token-file", dir_ + "/client.token"}, {}, &out), 0) << out;
  EXPECT_NE(out.find("worm1.csv"), std::string::npos) << out;
  EXPECT_EQ(Cli({"jobs", "show", std::to_string(id)},
                {{"WORMDRAG_SERVER", address_}, {"WORMDRAG_TOKEN", "client-secret"}}, &out),
            0)
      << out;
  EXPECT_NE(out.find("job " + std::to_string(id)), std::string::npos) << out;
  // The file wins over the environment; the worker's file is refused.
  EXPECT_NE(Cli({"jobs", "list", "--server", address_, "--token-file", dir_ + "/worker.token"},
                {{"WORMDRAG_TOKEN", "client-secret"}}, &out),
            0);
  EXPECT_NE(out.find("the worker token is not accepted by JobService"), std::string::npos) << out;
  EXPECT_EQ(Cli({"cancel", std::to_string(id), "--server", address_, "--token-file", dir_ + "/client.token"}, {}, &out),
            0)
      << out;

  std::ofstream(dir_ + "/empty.token") << "\n";
  for (const std::string cmd : {"submit", "watch", "cancel", "results", "jobs"}) {
    std::vector<std::string> args = {cmd};
    if (cmd == "submit") {
      args.push_back(dir_ + "/none1.csv");
      args.push_back(dir_ + "/none2.csv");
    } else if (cmd == "jobs") {
      args.push_back("list");
    } else {
      args.push_back("1");
    }
    for (const std::string& a : std::vector<std::string>{"--server", address_, "--token-file", dir_ + "/empty.token"})
      args.push_back(a);
    EXPECT_EQ(Cli(args, {}, &out), 2) << cmd << ": " << out;
    EXPECT_NE(out.find("token file " + dir_ + "/empty.token: empty"), std::string::npos) << cmd << ": " << out;
  }
}

// The CLI tells a token of the other role from a missing or wrong one: the worker token
// given to a client command is PERMISSION_DENIED, exit 2, with a message saying which
// token the command needs; a wrong token stays UNAUTHENTICATED, exit 1, without it.
TEST_F(CredentialsTest, CliTellsTheWorkerTokenFromAWrongOne) {
  StartWithTwoTokens();
  const int64_t id = Submit("client-secret");
  std::ofstream(dir_ + "/wrong.token") << "nobody-knows-this\n";
  const std::string worker_file = dir_ + "/worker.token", wrong_file = dir_ + "/wrong.token";
  std::string out;
  for (const std::string cmd : {"jobs", "cancel", "results", "watch"}) {
    const std::string arg = cmd == "jobs" ? "list" : std::to_string(id);
    EXPECT_EQ(Cli({cmd, arg, "--server", address_, "--token-file", worker_file}, {}, &out), 2) << cmd << ": " << out;
    EXPECT_NE(out.find("wormdrag " + cmd + ": server " + address_ +
                       " knows this token but not as a client's: the "
                       "worker token is not accepted by JobService"),
              std::string::npos)
        << out;
    EXPECT_NE(out.find("client commands need the client token (--token-file FILE or $WORMDRAG_TOKEN), not the one "
                       "given to workers"),
              std::string::npos)
        << out;
    EXPECT_EQ(Cli({cmd, arg, "--server", address_, "--token-file", wrong_file}, {}, &out), 1) << cmd << ": " << out;
    EXPECT_NE(out.find("server " + address_ + " refused the call: invalid token"), std::string::npos) << out;
    EXPECT_EQ(out.find("given to workers"), std::string::npos) << out;
  }
  EXPECT_NE(GetJob(id, "client-secret").state(), v2::JOB_STATE_CANCELLED) << "a refused cancel went through";
}

}  // namespace
}  // namespace wormdrag
