// A fixture for tests of the service with real processes: a wormdrag-server on a
// free loopback port with its SQLite file in a temporary directory, wormdrag-worker
// processes, the CLI, raw gRPC calls with or without a token, and the comparison of
// a finished job with an embedded run of the same job.
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"
#include "proto/convert.h"
#include "tests/integration/health.h"
#include "tests/integration/process.h"
#include "tests/integration/small_pair.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace wormdrag::itest {

namespace v2 = wormdrag::v2;
using namespace std::chrono_literals;

class ServiceFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/wormdrag-itest-XXXXXX";
    dir_ = mkdtemp(tmpl);
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    db_ = dir_ + "/coordinator.db";
  }
  void TearDown() override {
    workers_.clear();
    server_.reset();
    if (!HasFailure() && !std::getenv("WORMDRAG_KEEP_TEST_LOGS"))
      std::filesystem::remove_all(dir_);
    else
      std::fprintf(stderr, "logs kept in %s\n", dir_.c_str());
  }

  void StartServer(std::vector<std::string> extra = {}, const std::string& log = "server.log") {
    std::vector<std::string> argv = {WORMDRAG_SERVER_BIN, "--listen", address_, "--db", db_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/" + log);
    ASSERT_TRUE(WaitFor([&] { return HealthStatus(Channel()) == 1; }, 20s))
        << "server did not become healthy: " << server_->Log();
  }
  // A worker named `id` with one thread; `extra` arguments, `env` variables.
  Process& StartWorker(const std::string& id, std::vector<std::string> extra = {},
                       const std::map<std::string, std::string>& env = {}) {
    std::vector<std::string> argv = {WORMDRAG_WORKER_BIN, "--server", address_, "--threads", "1", "--id", id};
    argv.insert(argv.end(), extra.begin(), extra.end());
    workers_.push_back(std::make_unique<Process>(argv, dir_ + "/" + id + ".log", env));
    return *workers_.back();
  }
  std::shared_ptr<grpc::Channel> Channel() { return grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()); }

  static bool WaitFor(const std::function<bool()>& pred, std::chrono::seconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      if (pred()) return true;
      std::this_thread::sleep_for(50ms);
    }
    return pred();
  }
  static void Prepare(grpc::ClientContext* ctx, const std::string& token, std::chrono::seconds limit = 10s) {
    if (!token.empty()) ctx->AddMetadata("authorization", "Bearer " + token);
    ctx->set_deadline(std::chrono::system_clock::now() + limit);
  }

  // A small estimation job: Phase 1 of (n_max + 1)^4 sets of 1 s recordings, no bootstrap.
  static std::array<JobInput, 2> Inputs() { return SmallPair(); }
  static JobOptions SmallOptions(int n_max = 3) {
    JobOptions o;
    o.estimate.search.n_max = n_max;
    o.estimate.eval.t_max = 1;
    o.bootstrap.replicates = 0;
    return o;
  }
  static v2::SubmitJobRequest RequestOf(const std::array<JobInput, 2>& in, const JobOptions& o) {
    v2::SubmitJobRequest req;
    req.mutable_recording1()->set_name(in[0].name);
    req.mutable_recording1()->set_content(in[0].content);
    req.mutable_recording2()->set_name(in[1].name);
    req.mutable_recording2()->set_content(in[1].content);
    rpc::OptionsToProto(o, req.mutable_options());
    return req;
  }
  grpc::Status TrySubmit(const std::string& token, int64_t* id, int n_max = 3) {
    const v2::SubmitJobRequest req = RequestOf(Inputs(), SmallOptions(n_max));
    grpc::ClientContext ctx;
    Prepare(&ctx, token, 30s);
    v2::SubmitJobResponse resp;
    grpc::Status st = v2::JobService::NewStub(Channel())->SubmitJob(&ctx, req, &resp);
    *id = resp.job_id();
    return st;
  }
  int64_t Submit(const std::string& token = "", int n_max = 3) {
    int64_t id = 0;
    grpc::Status st = TrySubmit(token, &id, n_max);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return id;
  }
  v2::Job GetJob(int64_t id, const std::string& token = "") {
    grpc::ClientContext ctx;
    Prepare(&ctx, token, 2s);
    v2::GetJobRequest req;
    req.set_job_id(id);
    v2::Job j;
    (void)v2::JobService::NewStub(Channel())->GetJob(&ctx, req, &j);
    return j;
  }
  static bool Terminal(v2::JobState s) {
    return s == v2::JOB_STATE_DONE || s == v2::JOB_STATE_FAILED || s == v2::JOB_STATE_CANCELLED;
  }
  // Waits for the job to end; its final record.
  v2::Job WaitEnded(int64_t id, const std::string& token = "", std::chrono::seconds limit = 300s) {
    EXPECT_TRUE(WaitFor([&] { return Terminal(GetJob(id, token).state()); }, limit))
        << "job " << id << " did not end: " << server_->Log();
    return GetJob(id, token);
  }

  // The job's survivors and estimate equal an embedded run's (one per n_max per test
  // binary), bit for bit.
  void ExpectSameAsEmbedded(int64_t id, int n_max = 3) {
    static std::map<int, std::pair<std::string, std::array<std::vector<EvaluationRecord>, 2>>> cache;
    if (!cache.count(n_max)) {
      auto store = JobStore::Open(dir_ + "/reference.db");
      ASSERT_TRUE(store.ok()) << store.status().ToString();
      bool reused = false;
      auto ref = SubmitEstimateJob(**store, Inputs(), SmallOptions(n_max), false, &reused);
      ASSERT_TRUE(ref.ok()) << ref.status().ToString();
      ASSERT_TRUE(RunEstimateJob(**store, *ref, LocalEvaluatorFactory(2)).ok());
      cache[n_max] = {nlohmann::json::parse((*store)->GetJob(*ref)->result_json)["estimate"].dump(),
                      {*(*store)->Survivors(*ref, 1), *(*store)->Survivors(*ref, 2)}};
    }
    const auto& [estimate, survivors] = cache[n_max];
    auto store = JobStore::Open(db_);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto job = (*store)->GetJob(id);
    ASSERT_TRUE(job.ok());
    ASSERT_EQ(job->state, JobState::kDone) << job->error;
    EXPECT_EQ(nlohmann::json::parse(job->result_json)["estimate"].dump(), estimate);
    for (int phase : {1, 2}) {
      auto got = (*store)->Survivors(id, phase);
      ASSERT_TRUE(got.ok());
      const auto& want = survivors[phase - 1];
      ASSERT_EQ(got->size(), want.size()) << "phase " << phase;
      for (size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ((*got)[i].set, want[i].set) << "phase " << phase << " rank " << i;
        EXPECT_EQ((*got)[i].e, want[i].e) << "phase " << phase << " rank " << i;
      }
    }
  }

  std::string dir_, address_, db_;
  std::unique_ptr<Process> server_;
  std::vector<std::unique_ptr<Process>> workers_;
};

}  // namespace wormdrag::itest
