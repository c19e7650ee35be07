// The service fixture with jobs of a given size (Spec) and the strict comparison of a
// finished job with an embedded run of the same job: its options, every Phase 1 E
// both stored, both phases' survivors, the estimate and the intervals, bit for bit.
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/jobs/estimate_job.h"
#include "proto/convert.h"
#include "tests/integration/service_fixture.h"
#include "tests/integration/small_pair.h"
#include "wormdrag/v2/jobs.grpc.pb.h"

namespace wormdrag::itest {

struct Spec {
  int n_max;
  double duration;
  int bootstrap;  // refits for the intervals (0 = none)
};

// 625 Phase 1 sets, about 1 s on 2 cores, and the 19 refits of a 90 % interval.
inline constexpr Spec kSmall{4, 1.0, 19};
inline constexpr Spec kLonger{6, 2.0, 0};  // 2401 sets of 2 s recordings, a few seconds

inline std::array<JobInput, 2> MakeInputs(double duration) {
  return SmallPair(duration);
}

inline JobOptions MakeOptions(const Spec& s) {
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

// The embedded run of the same job, once per spec and test binary.
inline const Reference& EmbeddedReference(const Spec& s, const std::string& dir) {
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

inline bool SameRecords(const std::vector<EvaluationRecord>& a, const std::vector<EvaluationRecord>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i].set == b[i].set) || a[i].e != b[i].e || a[i].phase != b[i].phase) return false;
  return true;
}

// Every set present in both lists has the same E (bit for bit), and some are.
inline bool SameWhereBoth(const std::vector<EvaluationRecord>& a, const std::vector<EvaluationRecord>& b) {
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

class ServiceTest : public ServiceFixture {
 protected:
  // Workers named w0, w1, … in the order they start.
  Process& StartWorker(std::vector<std::string> extra = {}) {
    return ServiceFixture::StartWorker("w" + std::to_string(workers_.size()), std::move(extra));
  }
  std::unique_ptr<v2::JobService::Stub> Jobs() { return v2::JobService::NewStub(Channel()); }

  static v2::SubmitJobRequest Request(const Spec& s) { return RequestOf(MakeInputs(s.duration), MakeOptions(s)); }
  int64_t Submit(const Spec& s) {
    grpc::ClientContext ctx;
    Prepare(&ctx, "", 30s);
    v2::SubmitJobResponse resp;
    grpc::Status st = Jobs()->SubmitJob(&ctx, Request(s), &resp);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return resp.job_id();
  }
  // The first message of a watch: live task counts.
  v2::JobProgress Snapshot(int64_t id) {
    grpc::ClientContext ctx;
    Prepare(&ctx, "", 5s);
    v2::WatchJobRequest req;
    req.set_job_id(id);
    auto reader = Jobs()->WatchJob(&ctx, req);
    v2::JobProgress p;
    reader->Read(&p);
    ctx.TryCancel();
    reader->Finish();
    return p;
  }
  // Polls GetJob until `pred` holds (the server may be down meanwhile).
  v2::Job WaitJob(int64_t id, const std::function<bool(const v2::Job&)>& pred, std::chrono::seconds limit = 120s) {
    v2::Job j;
    if (WaitFor(
            [&] {
              j = GetJob(id);
              return pred(j);
            },
            limit))
      return j;
    ADD_FAILURE() << "job " << id << " did not reach the expected state; last state " << j.state() << " phase "
                  << j.phase() << " " << j.sets_done() << "/" << j.sets_total() << " error " << j.error();
    return j;
  }
  v2::Job WaitDone(int64_t id, std::chrono::seconds limit = 120s) {
    return WaitJob(
        id, [](const v2::Job& j) { return Terminal(j.state()); }, limit);
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
};

}  // namespace wormdrag::itest
