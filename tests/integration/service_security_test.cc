// Who may use the service, with real processes on 127.0.0.1: a token for clients and
// workers, mutual TLS, and submissions that are refused with the right status and
// store nothing. A job that is let in ends identical to an embedded run of it.
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/jobs/estimate_job.h"
#include "core/store/job_store.h"
#include "proto/convert.h"
#include "tests/integration/spec_fixture.h"
#include "wormdrag/v2/jobs.grpc.pb.h"

namespace wormdrag::itest {
namespace {

TEST_F(ServiceTest, UnauthenticatedClientAndWorkerAreRejected) {
  StartServer({"--token", "s3cret"});
  // A client without the token: UNAUTHENTICATED, nothing stored.
  auto in = MakeInputs(kSmall.duration);
  for (int j = 0; j < 2; ++j) std::ofstream(dir_ + "/" + in[j].name) << in[j].content;
  Process anon({WORMDRAG_CLI_BIN, "submit", dir_ + "/worm1.csv", dir_ + "/worm2.csv", "--server", address_, "--n-max",
                "4", "--t-max", "1"},
               dir_ + "/anon.log");
  EXPECT_NE(anon.Wait(), 0);
  EXPECT_NE(anon.Log().find("requires a token"), std::string::npos) << anon.Log();
  {
    auto stub = Jobs();
    grpc::ClientContext ctx;
    ctx.AddMetadata("authorization", "Bearer wrong");
    v2::ListJobsResponse resp;
    EXPECT_EQ(stub->ListJobs(&ctx, v2::ListJobsRequest(), &resp).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
  // A worker with a wrong token gives up with exit code 2.
  Process& bad = StartWorker({"--token", "wrong"});
  EXPECT_EQ(bad.Wait(), 2) << bad.Log();
  EXPECT_NE(bad.Log().find("invalid token"), std::string::npos) << bad.Log();
  {
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok());
    EXPECT_TRUE((*store)->ListJobs()->empty()) << "a rejected request stored a job";
  }
  // With the token (from the environment) everything works.
  std::map<std::string, std::string> env = {{"WORMDRAG_TOKEN", "s3cret"}};
  workers_.push_back(std::make_unique<Process>(
      std::vector<std::string>{WORMDRAG_WORKER_BIN, "--server", address_, "--threads", "2"}, dir_ + "/good.log", env));
  Process ok({WORMDRAG_CLI_BIN, "submit", dir_ + "/worm1.csv", dir_ + "/worm2.csv", "--server", address_, "--n-max",
              "4", "--t-max", "1", "--bootstrap", "19", "--wait"},
             dir_ + "/ok.log", env);
  ASSERT_EQ(ok.Wait(), 0) << ok.Log();
  ExpectSameAsEmbedded(1, kSmall);
}

TEST_F(ServiceTest, MalformedSubmissionsStoreNothing) {
  StartServer({"--max-sets", "20000", "--max-message-mb", "1"});
  auto stub = Jobs();
  auto submit = [&](const v2::SubmitJobRequest& req) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 10s);
    v2::SubmitJobResponse resp;
    return stub->SubmitJob(&ctx, req, &resp);
  };
  v2::SubmitJobRequest missing = Request(kSmall);
  missing.clear_recording2();
  EXPECT_EQ(submit(missing).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v2::SubmitJobRequest garbage = Request(kSmall);
  garbage.mutable_recording2()->set_content("t,x0,y0\n0,abc,1\n");
  auto st = submit(garbage);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("worm2.csv"), std::string::npos) << st.error_message();
  v2::SubmitJobRequest bad_option = Request(kSmall);
  bad_option.mutable_options()->set_d1(0.0);  // a percentage in (0, 100]
  EXPECT_EQ(submit(bad_option).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v2::SubmitJobRequest nan_option = Request(kSmall);
  nan_option.mutable_options()->set_t_max(std::nan(""));
  EXPECT_EQ(submit(nan_option).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v2::SubmitJobRequest huge_grid = Request(kSmall);
  huge_grid.mutable_options()->set_n_max(20);  // 21^4 = 194481 sets > --max-sets 20000
  EXPECT_EQ(submit(huge_grid).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Diagnosis jobs: bad options, an effect outside the catalogue, too many replicates,
  // both job types at once.
  auto diagnosis = [&](const std::function<void(v2::DiagnoseOptions*)>& edit) {
    v2::SubmitJobRequest r = Request(kSmall);
    r.clear_options();
    edit(r.mutable_diagnose());
    return submit(r);
  };
  EXPECT_EQ(diagnosis([](v2::DiagnoseOptions* o) { o->set_null_replicates(1); }).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  st = diagnosis([](v2::DiagnoseOptions* o) { o->add_effects("stretch"); });
  EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(st.error_message().find("stretch"), std::string::npos) << st.error_message();
  EXPECT_EQ(diagnosis([](v2::DiagnoseOptions* o) { o->add_start(1); }).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(diagnosis([](v2::DiagnoseOptions* o) { o->set_blocks(100); }).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);  // too few frames for 100 blocks
  EXPECT_EQ(diagnosis([](v2::DiagnoseOptions* o) { o->set_null_replicates(60); }).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
  v2::SubmitJobRequest both = Request(kSmall);
  both.mutable_diagnose();
  EXPECT_EQ(submit(both).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  v2::SubmitJobRequest huge_message = Request(kSmall);
  huge_message.mutable_recording1()->set_content(std::string(2 << 20, 'x'));
  EXPECT_EQ(submit(huge_message).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  {
    grpc::ClientContext ctx;
    v2::GetJobRequest req;
    req.set_job_id(42);
    v2::Job j;
    EXPECT_EQ(stub->GetJob(&ctx, req, &j).error_code(), grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext ctx;
    v2::CancelJobRequest req;
    req.set_job_id(-1);
    v2::CancelJobResponse r;
    EXPECT_EQ(stub->CancelJob(&ctx, req, &r).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  }
  auto store = JobStore::Open(db_);
  ASSERT_TRUE(store.ok());
  EXPECT_TRUE((*store)->ListJobs()->empty()) << "a rejected submission stored a job";
  const std::string hash = Sha256Hex(Request(kSmall).recording1().content());
  EXPECT_EQ((*store)->GetDataset(hash).status().code(), Status::Code::kNotFound) << "a rejected submission stored data";
}

// Certificates made here with the openssl command: a CA, a server certificate for
// 127.0.0.1 and a client certificate, all signed by the CA, plus a second CA that
// signed nothing the server knows.
void MakeCertificates(const std::string& dir) {
  const std::string ext = dir + "/san.ext";
  std::ofstream(ext) << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
  const std::vector<std::string> cmds = {
      "openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=wormdrag-test-ca -keyout ca.key -out ca.pem",
      "openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=other-ca -keyout other.key -out other.pem",
      "openssl req -newkey rsa:2048 -nodes -subj /CN=127.0.0.1 -keyout server.key -out server.csr",
      "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 2 -extfile san.ext -out "
      "server.pem",
      "openssl req -newkey rsa:2048 -nodes -subj /CN=lab-worker -keyout client.key -out client.csr",
      "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 2 -out client.pem"};
  for (const auto& c : cmds) {
    const std::string full = "cd " + dir + " && " + c + " >>openssl.log 2>&1";
    ASSERT_EQ(std::system(full.c_str()), 0) << c;
  }
}

TEST_F(ServiceTest, MutualTlsAcceptsOnlyCertifiedPeers) {
  MakeCertificates(dir_);
  if (HasFatalFailure()) return;
  const std::string d = dir_ + "/";
  server_ = std::make_unique<Process>(
      std::vector<std::string>{WORMDRAG_SERVER_BIN, "--listen", address_, "--db", db_, "--tls-cert", d + "server.pem",
                               "--tls-key", d + "server.key", "--tls-client-ca", d + "ca.pem"},
      dir_ + "/server.log");
  auto in = MakeInputs(kSmall.duration);
  for (int j = 0; j < 2; ++j) std::ofstream(d + in[j].name) << in[j].content;
  const std::vector<std::string> tls = {"--tls-ca",       d + "ca.pem", "--tls-cert",
                                        d + "client.pem", "--tls-key",  d + "client.key"};
  auto cli = [&](const std::string& name, std::vector<std::string> argv) {
    argv.insert(argv.begin(), WORMDRAG_CLI_BIN);
    return std::make_unique<Process>(argv, dir_ + "/" + name + ".log");
  };
  // Wait until the TLS server answers a certified client.
  for (int i = 0;; ++i) {
    std::vector<std::string> argv = {"jobs", "list", "--server", address_};
    argv.insert(argv.end(), tls.begin(), tls.end());
    auto p = cli("probe" + std::to_string(i), argv);
    if (p->Wait() == 0) break;
    ASSERT_LT(i, 100) << "the TLS server never answered: " << server_->Log() << p->Log();
    std::this_thread::sleep_for(100ms);
  }
  // Refused: plaintext; TLS without a client certificate; a client whose CA does not
  // know the server; a client certificate with its key missing (a usage error).
  {
    auto plain = cli("plain", {"jobs", "list", "--server", address_});
    EXPECT_NE(plain->Wait(), 0) << plain->Log();
    auto no_cert = cli("nocert", {"jobs", "list", "--server", address_, "--tls-ca", d + "ca.pem"});
    EXPECT_NE(no_cert->Wait(), 0) << no_cert->Log();
    auto wrong_ca = cli("wrongca", {"jobs", "list", "--server", address_, "--tls-ca", d + "other.pem", "--tls-cert",
                                    d + "client.pem", "--tls-key", d + "client.key"});
    EXPECT_NE(wrong_ca->Wait(), 0) << wrong_ca->Log();
    auto half = cli("half",
                    {"jobs", "list", "--server", address_, "--tls-ca", d + "ca.pem", "--tls-cert", d + "client.pem"});
    EXPECT_NE(half->Wait(), 0);
    EXPECT_NE(half->Log().find("needs both --tls-cert and --tls-key"), std::string::npos) << half->Log();
    std::vector<std::string> submit = {
        "submit", d + "worm1.csv", d + "worm2.csv", "--server", address_, "--n-max", "4", "--t-max",
        "1",      "--tls-ca",      d + "ca.pem"};
    auto rejected = cli("rejected-submit", submit);
    EXPECT_NE(rejected->Wait(), 0) << rejected->Log();
  }
  // A worker without a client certificate never gets work; it keeps retrying.
  auto uncertified = std::make_unique<Process>(
      std::vector<std::string>{WORMDRAG_WORKER_BIN, "--server", address_, "--threads", "1", "--id", "uncertified",
                               "--tls-ca", d + "ca.pem"},
      dir_ + "/uncertified.log");
  // Certified worker and client: the job runs and equals the embedded run.
  std::vector<std::string> wargv = {WORMDRAG_WORKER_BIN, "--server", address_, "--threads", "2", "--id", "certified"};
  wargv.insert(wargv.end(), tls.begin(), tls.end());
  workers_.push_back(std::make_unique<Process>(wargv, dir_ + "/certified.log"));
  std::vector<std::string> submit = {
      "submit", d + "worm1.csv", d + "worm2.csv", "--server", address_, "--n-max", "4", "--t-max", "1", "--bootstrap",
      "19",     "--wait"};
  submit.insert(submit.end(), tls.begin(), tls.end());
  auto ok = cli("submit", submit);
  ASSERT_EQ(ok->Wait(), 0) << ok->Log();
  {
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok());
    EXPECT_EQ((*store)->ListJobs()->size(), 1u) << "a refused submission was stored";
  }
  ExpectSameAsEmbedded(1, kSmall);
  const std::string ulog = uncertified->Log();
  EXPECT_EQ(ulog.find("event=connected"), std::string::npos) << ulog;
  EXPECT_EQ(ulog.find("event=task_reported"), std::string::npos) << ulog;
  EXPECT_NE(ulog.find("event=coordinator_unreachable"), std::string::npos) << ulog;
}

}  // namespace
}  // namespace wormdrag::itest
