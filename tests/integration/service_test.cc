// The distributed service with real processes on 127.0.0.1: wormdrag-server,
// wormdrag-worker and the CLI, a real SQLite file, real SIGKILL/SIGSTOP/SIGTERM.
// Every fault test ends with the job done and its result identical to an embedded
// run of the same job (RunEstimateJob + LocalEvaluatorFactory).
#include <signal.h>

#include <chrono>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/diagnose/diagnosis.h"
#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "proto/convert.h"
#include "proto/result_convert.h"
#include "tests/integration/spec_fixture.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace wormdrag::itest {
namespace {

TEST_F(ServiceTest, ThreeWorkersGiveTheEmbeddedResultThroughTheCli) {
  StartServer();
  for (int i = 0; i < 3; ++i) StartWorker();
  auto in = MakeInputs(kSmall.duration);
  for (int j = 0; j < 2; ++j) std::ofstream(dir_ + "/" + in[j].name) << in[j].content;
  Process submit({WORMDRAG_CLI_BIN, "submit", dir_ + "/worm1.csv", dir_ + "/worm2.csv", "--server", address_, "--n-max",
                  "4", "--t-max", "1", "--bootstrap", "19", "--wait"},
                 dir_ + "/submit.log");
  ASSERT_EQ(submit.Wait(), 0) << submit.Log();
  EXPECT_NE(submit.Log().find("phase3"), std::string::npos) << submit.Log();
  ExpectSameAsEmbedded(1, kSmall);
  EXPECT_NE(submit.Log().find(" intervals from "), std::string::npos) << submit.Log();
  // Phase 3's calls of one or two lane groups were split by worm, to the same result.
  bool worm_shares = false;
  for (auto& w : workers_) worm_shares = worm_shares || w->Log().find(" worm=2") != std::string::npos;
  EXPECT_TRUE(worm_shares) << "no task asked for one worm's share";
  // Phase 3's scale rays went out with their group cuts, and workers stopped sets
  // against them, to the same result. A worker of one thread reports each task
  // before it leases the next.
  bool ray_abandoned = false;
  for (auto& w : workers_) {
    std::istringstream log(w->Log());
    bool groups = false;
    for (std::string line; std::getline(log, line);) {
      if (line.find("event=task_leased") != std::string::npos) groups = line.find(" cut=groups") != std::string::npos;
      if (groups && line.find("event=task_reported") != std::string::npos &&
          line.find(" abandoned=0 ") == std::string::npos)
        ray_abandoned = true;
    }
  }
  EXPECT_TRUE(ray_abandoned) << "no set of a scale ray was abandoned against its group's cut";
  {
    // GetResults carries the stored result as a typed message, every key of it.
    auto stub = Jobs();
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 30s);
    v2::GetResultsRequest req;
    req.set_job_id(1);
    v2::GetResultsResponse resp;
    ASSERT_TRUE(stub->GetResults(&ctx, req, &resp).ok());
    ASSERT_TRUE(resp.has_estimate());
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok());
    const std::string stored = (*store)->GetJob(1)->result_json;
    v2::EstimateResult strict;
    Status st = rpc::ResultFromJson(stored, &strict, {.strict = true});
    ASSERT_TRUE(st.ok()) << st.ToString();
    EXPECT_EQ(resp.estimate().SerializeAsString(), strict.SerializeAsString());
    const auto est = nlohmann::json::parse(stored)["estimate"];
    EXPECT_EQ(resp.estimate().estimate().mu_n(), est["mu_n"].get<double>());
    EXPECT_EQ(resp.estimate().bootstrap().replicates() + resp.estimate().bootstrap().failed(), 19);
  }
  {
    // The workers abandoned sets against the cut the tasks carried.
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok());
    const auto phase1 = nlohmann::json::parse((*store)->GetJob(1)->result_json)["phases"][0];
    EXPECT_GT(phase1["abandoned"].get<int64_t>(), 0) << phase1.dump();
    EXPECT_LT(phase1["knots"].get<int64_t>(), phase1["knots_full"].get<int64_t>()) << phase1.dump();
  }
  // The other commands, through the environment variable instead of --server.
  std::map<std::string, std::string> env = {{"WORMDRAG_SERVER", address_}};
  Process list({WORMDRAG_CLI_BIN, "jobs", "list"}, dir_ + "/list.log", env);
  ASSERT_EQ(list.Wait(), 0) << list.Log();
  EXPECT_NE(list.Log().find("done"), std::string::npos) << list.Log();
  // The job's options reach the CLI typed and print as the canonical text the store keeps.
  Process show({WORMDRAG_CLI_BIN, "jobs", "show", "1"}, dir_ + "/show.log", env);
  ASSERT_EQ(show.Wait(), 0) << show.Log();
  EXPECT_NE(show.Log().find("options: " + EmbeddedReference(kSmall, dir_).options_json + "\n"), std::string::npos)
      << show.Log();
  Process results({WORMDRAG_CLI_BIN, "results", "1", "--top", "3", "--format", "csv"}, dir_ + "/results.log", env);
  ASSERT_EQ(results.Wait(), 0) << results.Log();
  EXPECT_NE(results.Log().find("phase,mu_n"), std::string::npos);
  Process cancel({WORMDRAG_CLI_BIN, "cancel", "1"}, dir_ + "/cancel.log", env);
  EXPECT_NE(cancel.Wait(), 0) << "cancelling a finished job must fail";
  EXPECT_NE(cancel.Log().find("already ended"), std::string::npos) << cancel.Log();
  // SIGTERM drains workers (exit 0) and stops the server (exit 0).
  for (auto& w : workers_) w->Signal(SIGTERM);
  for (auto& w : workers_) EXPECT_EQ(w->Wait(), 0) << w->Log();
  server_->Signal(SIGTERM);
  EXPECT_EQ(server_->Wait(), 0) << server_->Log();
}

TEST_F(ServiceTest, WorkerKilledMidTaskIsNotAFailure) {
  // --max-attempts 1: were a lost lease counted as a failure, the job would fail.
  StartServer({"--lease-seconds", "2", "--max-attempts", "1", "--chunk-sets", "64"});
  Process& a = StartWorker();
  const int64_t id = Submit(kLonger);
  WaitJob(id, [](const v2::Job& j) { return j.phase() == "phase1" && j.sets_done() > 0; });
  a.Signal(SIGKILL);
  EXPECT_EQ(a.Wait(), 128 + SIGKILL);
  StartWorker();
  auto j = WaitDone(id);
  ASSERT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  ExpectSameAsEmbedded(id, kLonger);
}

TEST_F(ServiceTest, CoordinatorKilledInPhase1ResumesFromSqlite) {
  const std::vector<std::string> flags = {"--lease-seconds", "3", "--chunk-sets", "64"};
  StartServer(flags);
  StartWorker();
  StartWorker();
  const int64_t id = Submit(kLonger);
  auto j = WaitJob(id, [](const v2::Job& j) { return j.phase() == "phase1" && j.sets_done() >= 600; });
  ASSERT_EQ(j.phase(), "phase1");
  ASSERT_LT(j.sets_done(), j.sets_total()) << "Phase 1 ended before the kill; make the job longer";
  server_->Signal(SIGKILL);
  EXPECT_EQ(server_->Wait(), 128 + SIGKILL);
  StartServer(flags);  // same port and file; the workers reconnect on their own
  auto done = WaitDone(id);
  ASSERT_EQ(done.state(), v2::JOB_STATE_DONE) << done.error();
  ExpectSameAsEmbedded(id, kLonger);
  EXPECT_NE(server_->Log().find("event=job_resumed job=" + std::to_string(id)), std::string::npos);
}

// Phase 3's residual vectors are not made durable (IsDurable): a coordinator killed in
// Phase 3 reuses the stored Phases 1-2 and runs Phase 3 again, to the same result.
TEST_F(ServiceTest, CoordinatorKilledInPhase3RunsItAgain) {
  StartServer();
  StartWorker();
  StartWorker();
  const int64_t id = Submit(kLonger);
  auto j = WaitJob(id, [](const v2::Job& j) { return j.phase() == "phase3" || j.state() == v2::JOB_STATE_DONE; });
  ASSERT_EQ(j.phase(), "phase3") << "the job ended before Phase 3 was seen; make it longer";
  server_->Signal(SIGKILL);
  EXPECT_EQ(server_->Wait(), 128 + SIGKILL);
  int64_t phase1_stored = 0;  // every Phase 1 E (sets abandoned early have none)
  {
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    phase1_stored = *(*store)->CountEvaluations(id, 1);
  }
  EXPECT_GT(phase1_stored, 0);
  StartServer();
  auto done = WaitDone(id);
  ASSERT_EQ(done.state(), v2::JOB_STATE_DONE) << done.error();
  ExpectSameAsEmbedded(id, kLonger);
  auto store = JobStore::Open(db_);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  const auto result = nlohmann::json::parse((*store)->GetJob(id)->result_json);
  EXPECT_GE(result["reused_evaluations"].get<int64_t>(), phase1_stored) << "Phase 1 was not reused from SQLite";
}

TEST_F(ServiceTest, WorkerStoppedPastItsLeaseAndResumed) {
  StartServer({"--lease-seconds", "2", "--chunk-sets", "128"});
  Process& a = StartWorker();
  const int64_t id = Submit(kLonger);
  WaitJob(id, [](const v2::Job& j) { return j.phase() == "phase1" && j.sets_done() > 0; });
  // Stop A while it holds a lease (it is the only worker, so a leased task is its).
  bool holding = false;
  for (int attempt = 0; attempt < 50 && !holding; ++attempt) {
    a.Signal(SIGSTOP);
    std::this_thread::sleep_for(100ms);
    holding = Snapshot(id).tasks_leased() > 0;
    if (!holding) a.Signal(SIGCONT);
  }
  ASSERT_TRUE(holding) << "could not stop the worker while it held a task";
  StartWorker();
  std::this_thread::sleep_for(3500ms);  // past the lease: its task went to the other worker
  a.Signal(SIGCONT);
  auto j = WaitDone(id);
  ASSERT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  ExpectSameAsEmbedded(id, kLonger);
  EXPECT_NE(server_->Log().find("expired; back to the queue"), std::string::npos) << server_->Log();
  a.Signal(SIGTERM);
  EXPECT_EQ(a.Wait(), 0) << a.Log();
}

TEST_F(ServiceTest, DuplicateAndBogusReportsAreIdempotent) {
  // The test holds its lease while it computes the task itself, without heartbeats: a
  // lease far longer than that can take on a loaded machine keeps the time it takes
  // out of what is tested (an expired lease would refuse the reports below).
  StartServer({"--lease-seconds", "600"});
  const int64_t id = Submit(kSmall);
  auto stub = v2::WorkerService::NewStub(Channel());
  // Act as a worker for one task: compute it with the same core code. The job's first
  // tasks are queued once its runner has prepared the recordings, which under load can
  // take longer than one lease poll: polls repeat until a task comes.
  v2::LeaseTaskResponse lease;
  const auto give_up = std::chrono::steady_clock::now() + 120s;
  while (!lease.has_task() && std::chrono::steady_clock::now() < give_up) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 60s);
    v2::LeaseTaskRequest req;
    req.set_worker_id("test");
    req.set_wait_ms(5000);
    ASSERT_TRUE(stub->LeaseTask(&ctx, req, &lease).ok());
  }
  ASSERT_TRUE(lease.has_task()) << "no task leased within 120 s: " << server_->Log();
  const v2::Task& t = lease.task();
  auto options = rpc::OptionsFromProto(t.estimate_options());
  ASSERT_TRUE(options.ok());
  auto in = MakeInputs(kSmall.duration);
  std::array<Kinematics, 2> k;
  for (int j = 0; j < 2; ++j) k[j] = *PrepareRecording(in[j].name, in[j].content, *options);
  auto pair = PairedPath::Create(k, {in[0].name, in[1].name},
                                 t.screening() ? options->estimate.ScreeningEval() : options->estimate.eval);
  ASSERT_TRUE(pair.ok());
  std::vector<Coefficients> sets;
  for (const auto& c : t.sets()) sets.push_back({c.mu_n(), c.mu_t(), c.eta_n(), c.eta_t()});
  std::vector<double> e;
  ASSERT_TRUE(LocalEvaluator(*pair, 1).Evaluate(sets, &e).ok());
  auto report = [&](const std::vector<double>& values, const std::string& task_id, v2::ReportResultResponse* resp) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 60s);
    v2::ReportResultRequest req;
    req.set_worker_id("test");
    req.set_task_id(task_id);
    req.set_lease_id(t.lease_id());
    for (double v : values) req.add_values(v);
    return stub->ReportResult(&ctx, req, resp);
  };
  v2::ReportResultResponse r1, r2, r3;
  // Wrong shape: rejected, nothing recorded.
  EXPECT_EQ(report({1.0}, t.task_id(), &r1).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(report(e, "t999-unknown", &r1).error_code(), grpc::StatusCode::NOT_FOUND);
  ASSERT_TRUE(report(e, t.task_id(), &r1).ok());
  EXPECT_FALSE(r1.duplicate());
  ASSERT_TRUE(report(e, t.task_id(), &r2).ok());
  EXPECT_TRUE(r2.duplicate());
  // A later, different result of the same task is acknowledged and ignored.
  std::vector<double> bogus(e.size(), 123.0);
  ASSERT_TRUE(report(bogus, t.task_id(), &r3).ok());
  EXPECT_TRUE(r3.duplicate());
  StartWorker();
  auto j = WaitDone(id, 300s);
  ASSERT_EQ(j.state(), v2::JOB_STATE_DONE) << j.error();
  ExpectSameAsEmbedded(id, kSmall);
}

TEST_F(ServiceTest, CancelStopsAJobAndTwoJobsShareWorkers) {
  StartServer();
  const int64_t first = Submit(kLonger);
  const int64_t second = Submit(kSmall);
  StartWorker();
  // Both progress with one worker (round-robin), then the long one is cancelled.
  WaitJob(first, [](const v2::Job& j) { return j.sets_done() > 0; });
  // One worker shares itself between both jobs, so the small one takes about as long
  // as both together: on a loaded machine (the benchmark beside the tests) that has
  // passed 120 s, hence the longer limit; it bounds a hang, it does not time anything.
  auto small = WaitDone(second, 400s);
  ASSERT_EQ(small.state(), v2::JOB_STATE_DONE) << small.error();
  {
    auto stub = Jobs();
    grpc::ClientContext ctx;
    v2::CancelJobRequest req;
    req.set_job_id(first);
    v2::CancelJobResponse r;
    grpc::Status st = stub->CancelJob(&ctx, req, &r);
    // The long job may (rarely) finish first on a fast machine.
    if (st.ok()) {
      auto j = WaitDone(first);
      EXPECT_EQ(j.state(), v2::JOB_STATE_CANCELLED);
    } else {
      EXPECT_EQ(st.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    }
  }
  ExpectSameAsEmbedded(second, kSmall);
}

// A diagnosis as a service job: the coordinator is killed (SIGKILL) while workers run
// its fits and restarted; the CLI's --wait follows it through the restart, and the
// result equals the embedded diagnosis of the same files with the same options.
TEST_F(ServiceTest, DiagnosisJobSurvivesACoordinatorKillAndMatchesEmbedded) {
  const std::string d = dir_ + "/";
  Process synth({WORMDRAG_CLI_BIN, "synth", "--pattern", "0.5,0/0.7,0.1", "--coef", "0.5,0.2,0.005,0.002", "--effect",
                 "lag=0.05", "--noise", "0.002", "--seed", "3", "--fps", "30", "--duration", "2", "--out", d + "synth"},
                d + "synth.log");
  ASSERT_EQ(synth.Wait(), 0) << synth.Log();
  const std::string k1 = d + "synth/worm1.csv", k2 = d + "synth/worm2.csv";
  StartServer();
  StartWorker();
  StartWorker();
  Process cli({WORMDRAG_CLI_BIN, "diagnose", k1, k2, "--server", address_, "--no-grid", "--null", "2", "--blocks", "4",
               "--effects", "lag,flow", "--wait", "--json", d + "remote.json"},
              d + "cli.log");
  // Kill the coordinator once some fits are durable, then restart it on the same file.
  // (A generous limit: the multi-start base fit and the blocked refit run as single
  // tasks on one worker thread each, and take well over a minute on a busy machine.)
  WaitJob(
      1, [](const v2::Job& j) { return j.phase() == "fits" && j.sets_done() >= 3; }, 400s);
  server_->Signal(SIGKILL);
  server_->Wait();
  StartServer();
  ASSERT_EQ(cli.Wait(), 0) << cli.Log() << server_->Log();
  EXPECT_NE(cli.Log().find("verdict: lag"), std::string::npos) << cli.Log();

  // The same diagnosis embedded.
  std::array<Kinematics, 2> ks;
  for (int j = 0; j < 2; ++j) {
    auto k = ReadKinematics(j == 0 ? k1 : k2);
    ASSERT_TRUE(k.ok()) << k.status().ToString();
    ks[j] = std::move(*k);
  }
  diagnose::DiagnoseOptions o;
  o.base_grid = false;
  o.null_replicates = 2;
  o.blocks = 4;
  o.effects = {"lag", "flow"};
  o.threads = 2;
  auto local = diagnose::RunDiagnosis(ks, {k1, k2}, o);
  ASSERT_TRUE(local.ok()) << local.status().ToString();
  std::ifstream in(d + "remote.json");
  auto remote = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(remote.is_discarded());
  // The CLI writes the typed result's JSON; the embedded diagnosis becomes it the same way.
  v2::DiagnosisResult typed;
  ASSERT_TRUE(rpc::ResultFromJson(local->ToJson(), &typed, {.strict = true}).ok());
  auto embedded = nlohmann::json::parse(rpc::ResultToJson(typed));
  remote.erase("seconds");
  embedded.erase("seconds");
  EXPECT_EQ(remote, embedded) << "the service's diagnosis differs from the embedded one";
  EXPECT_EQ(remote["verdict"], "lag");
  // Both workers took part; the restarted coordinator answered stored fits itself.
  int with_fits = 0;
  for (const auto& w : workers_) with_fits += w->Log().find("event=task_reported") != std::string::npos;
  EXPECT_EQ(with_fits, 2);
}

}  // namespace
}  // namespace wormdrag::itest
