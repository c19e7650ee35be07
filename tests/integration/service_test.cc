// The distributed service with real processes on 127.0.0.1: wormdrag-server,
// wormdrag-worker and the CLI, a real SQLite file, real SIGKILL/SIGSTOP/SIGTERM.
// Every fault test ends with the job done and its result identical to an embedded
// run of the same job (RunEstimateJob + LocalEvaluatorFactory), or with the right
// error and nothing stored.
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/diagnose/diagnosis.h"
#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"
#include "proto/convert.h"
#include "proto/result_convert.h"
#include "proto/rpc_util.h"
#include "tests/integration/health.h"
#include "tests/integration/process.h"
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

// ------------------------------------------------------------------ jobs

struct Spec {
  int n_max;
  double duration;
  int bootstrap;  // refits for the intervals (0 = none)
};

std::array<JobInput, 2> MakeInputs(double duration) {
  return itest::SmallPair(duration);
}

JobOptions MakeOptions(const Spec& s) {
  JobOptions o;
  o.estimate.search.n_max = s.n_max;
  o.estimate.eval.t_max = s.duration;
  o.bootstrap.replicates = s.bootstrap;
  return o;
}

struct Reference {
  std::vector<EvaluationRecord> phase1, survivors1, survivors2;
  nlohmann::json estimate, bootstrap;
  std::string options_json;
};

// The embedded run of the same job, once per spec.
const Reference& EmbeddedReference(const Spec& s, const std::string& dir) {
  static std::map<std::pair<int, double>, Reference> cache;
  auto key = std::make_pair(s.n_max, s.duration);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  const std::string db = dir + "/reference-" + std::to_string(s.n_max) + ".db";
  auto store = JobStore::Open(db);
  EXPECT_TRUE(store.ok());
  bool reused = false;
  auto id = SubmitEstimateJob(**store, MakeInputs(s.duration), MakeOptions(s), false, &reused);
  EXPECT_TRUE(id.ok()) << id.status().ToString();
  Status st = RunEstimateJob(**store, *id, LocalEvaluatorFactory(2));
  EXPECT_TRUE(st.ok()) << st.ToString();
  Reference r;
  r.phase1 = *(*store)->Evaluations(*id, 1);
  r.survivors1 = *(*store)->Survivors(*id, 1);
  r.survivors2 = *(*store)->Survivors(*id, 2);
  auto job = (*store)->GetJob(*id);
  r.estimate = nlohmann::json::parse(job->result_json)["estimate"];
  r.bootstrap = nlohmann::json::parse(job->result_json).value("bootstrap", nlohmann::json());
  r.options_json = job->options_json;
  return cache[key] = r;
}

bool SameRecords(const std::vector<EvaluationRecord>& a, const std::vector<EvaluationRecord>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i].set == b[i].set) || a[i].e != b[i].e || a[i].phase != b[i].phase) return false;
  return true;
}

// Every set present in both lists has the same E (bit for bit), and some are.
bool SameWhereBoth(const std::vector<EvaluationRecord>& a, const std::vector<EvaluationRecord>& b) {
  std::map<std::array<double, 4>, double> by_set;
  for (const auto& r : b) by_set[r.set.AsArray()] = r.e;
  size_t common = 0;
  for (const auto& r : a) {
    auto it = by_set.find(r.set.AsArray());
    if (it == by_set.end()) continue;
    ++common;
    if (it->second != r.e) return false;
  }
  return common > 0;
}

// ------------------------------------------------------------------ fixture

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/wormdrag-svc-XXXXXX";
    dir_ = mkdtemp(tmpl);
    port_ = FreePort();
    address_ = "127.0.0.1:" + std::to_string(port_);
    db_ = dir_ + "/coordinator.db";
  }
  void TearDown() override {
    workers_.clear();
    server_.reset();
    if (!HasFailure())
      fs::remove_all(dir_);
    else
      std::fprintf(stderr, "logs kept in %s\n", dir_.c_str());
  }

  void StartServer(std::vector<std::string> extra = {}) {
    std::vector<std::string> argv = {WORMDRAG_SERVER_BIN, "--listen", address_, "--db", db_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/server.log");
    WaitServing();
  }
  Process& StartWorker(std::vector<std::string> extra = {}) {
    std::vector<std::string> argv = {
        WORMDRAG_WORKER_BIN, "--server", address_, "--threads", "1", "--id", "w" + std::to_string(workers_.size())};
    argv.insert(argv.end(), extra.begin(), extra.end());
    workers_.push_back(std::make_unique<Process>(argv, dir_ + "/worker" + std::to_string(workers_.size()) + ".log"));
    return *workers_.back();
  }

  std::shared_ptr<grpc::Channel> Channel() { return grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()); }
  std::unique_ptr<v2::JobService::Stub> Jobs() { return v2::JobService::NewStub(Channel()); }

  bool Serving() { return itest::HealthStatus(Channel()) == 1; }
  // A deadline, not a count of polls: on a loaded machine a start can take seconds.
  void WaitServing() {
    const auto end = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < end) {
      if (Serving()) return;
      std::this_thread::sleep_for(50ms);
    }
    FAIL() << "server did not become healthy: " << server_->Log();
  }

  v2::SubmitJobRequest Request(const Spec& s) {
    auto in = MakeInputs(s.duration);
    v2::SubmitJobRequest req;
    req.mutable_recording1()->set_name(in[0].name);
    req.mutable_recording1()->set_content(in[0].content);
    req.mutable_recording2()->set_name(in[1].name);
    req.mutable_recording2()->set_content(in[1].content);
    rpc::OptionsToProto(MakeOptions(s), req.mutable_options());
    return req;
  }
  int64_t Submit(const Spec& s) {
    auto stub = Jobs();
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 30s);
    v2::SubmitJobResponse resp;
    grpc::Status st = stub->SubmitJob(&ctx, Request(s), &resp);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return resp.job_id();
  }
  // The first message of a watch: live task counts.
  v2::JobProgress Snapshot(int64_t id) {
    auto stub = Jobs();
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 5s);
    v2::WatchJobRequest req;
    req.set_job_id(id);
    auto reader = stub->WatchJob(&ctx, req);
    v2::JobProgress p;
    reader->Read(&p);
    ctx.TryCancel();
    reader->Finish();
    return p;
  }
  // Polls GetJob until `pred` holds (the server may be down meanwhile).
  v2::Job WaitJob(int64_t id, const std::function<bool(const v2::Job&)>& pred, std::chrono::seconds limit = 120s) {
    const auto end = std::chrono::steady_clock::now() + limit;
    v2::Job j;
    while (std::chrono::steady_clock::now() < end) {
      auto stub = Jobs();
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + 2s);
      v2::GetJobRequest req;
      req.set_job_id(id);
      if (stub->GetJob(&ctx, req, &j).ok() && pred(j)) return j;
      std::this_thread::sleep_for(20ms);
    }
    ADD_FAILURE() << "job " << id << " did not reach the expected state; last state " << j.state() << " phase "
                  << j.phase() << " " << j.sets_done() << "/" << j.sets_total() << " error " << j.error();
    return j;
  }
  v2::Job WaitDone(int64_t id, std::chrono::seconds limit = 120s) {
    return WaitJob(
        id,
        [](const v2::Job& j) {
          return j.state() == v2::JOB_STATE_DONE || j.state() == v2::JOB_STATE_FAILED ||
                 j.state() == v2::JOB_STATE_CANCELLED;
        },
        limit);
  }

  // The job in the coordinator's file matches the embedded run bit for bit.
  void ExpectSameAsEmbedded(int64_t id, const Spec& s) {
    const Reference& ref = EmbeddedReference(s, dir_);
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto job = (*store)->GetJob(id);
    ASSERT_TRUE(job.ok());
    ASSERT_EQ(job->state, JobState::kDone) << job->error;
    EXPECT_EQ(job->options_json, ref.options_json);
    auto p1 = (*store)->Evaluations(id, 1);
    ASSERT_TRUE(p1.ok());
    // Which sets early abandoning stops depends on timing, so each run stores its own
    // subset of Phase 1; every E stored by both is the same double.
    EXPECT_TRUE(SameWhereBoth(*p1, ref.phase1)) << "Phase 1 E differ from the embedded run";
    EXPECT_TRUE(SameRecords(*(*store)->Survivors(id, 1), ref.survivors1));
    EXPECT_TRUE(SameRecords(*(*store)->Survivors(id, 2), ref.survivors2));
    const auto est = nlohmann::json::parse(job->result_json)["estimate"];
    EXPECT_EQ(est, ref.estimate) << "final estimate differs: " << est.dump() << " vs " << ref.estimate.dump();
    // Bootstrap refits ran as worker tasks; each is deterministic in its index.
    const auto boot = nlohmann::json::parse(job->result_json).value("bootstrap", nlohmann::json());
    EXPECT_EQ(boot, ref.bootstrap) << "intervals differ: " << boot.dump() << " vs " << ref.bootstrap.dump();
    if (s.bootstrap > 0) { EXPECT_EQ(boot.value("replicates", 0) + boot.value("failed", 0), s.bootstrap); }
  }

  std::string dir_, address_, db_;
  int port_ = 0;
  std::unique_ptr<Process> server_;
  std::vector<std::unique_ptr<Process>> workers_;
};

const Spec kSmall{4, 1.0, 10};  // 625 Phase 1 sets, about 1 s on 2 cores, and 10 bootstrap refits
const Spec kLonger{6, 2.0, 0};  // 2401 sets of 2 s recordings, a few seconds

// ------------------------------------------------------------------ tests

TEST_F(ServiceTest, ThreeWorkersGiveTheEmbeddedResultThroughTheCli) {
  StartServer();
  for (int i = 0; i < 3; ++i) StartWorker();
  auto in = MakeInputs(kSmall.duration);
  for (int j = 0; j < 2; ++j) std::ofstream(dir_ + "/" + in[j].name) << in[j].content;
  Process submit({WORMDRAG_CLI_BIN, "submit", dir_ + "/worm1.csv", dir_ + "/worm2.csv", "--server", address_, "--n-max",
                  "4", "--t-max", "1", "--bootstrap", "10", "--wait"},
                 dir_ + "/submit.log");
  ASSERT_EQ(submit.Wait(), 0) << submit.Log();
  EXPECT_NE(submit.Log().find("phase3"), std::string::npos) << submit.Log();
  ExpectSameAsEmbedded(1, kSmall);
  EXPECT_NE(submit.Log().find(" intervals from "), std::string::npos) << submit.Log();
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
    EXPECT_EQ(resp.estimate().bootstrap().replicates() + resp.estimate().bootstrap().failed(), 10);
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
              "4", "--t-max", "1", "--bootstrap", "10", "--wait"},
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
      "10",     "--wait"};
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
}  // namespace wormdrag
