#include "core/jobs/estimate_job.h"

#include <unistd.h>
#include <cmath>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

const Coefficients kTruth{0.45, 0.15, 0.004, 0.002};

std::string Recording(int loco) {
  SimOptions sim;
  RecordingSpec spec;
  spec.fps = 100;
  spec.duration = 1;
  auto k = GenerateRecording(Locomotion(loco), kTruth, sim, spec);
  EXPECT_TRUE(k.ok());
  return FormatKinematics(*k);
}

JobOptions SmallOptions() {
  JobOptions o;
  o.estimate.eval.t_max = 1;
  o.estimate.search.n_max = 3;
  o.estimate.search.d_mu = 0.2;
  o.estimate.search.d_eta = 0.002;
  o.estimate.search.d1 = 5;
  o.estimate.search.d2 = 2;
  o.estimate.phase3.scale_rounds = 2;
  o.smoothing = SmoothingMethod::kNone;
  o.bootstrap.replicates = 0;
  return o;
}

class JobsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = ::testing::TempDir() + "/jobs_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db";
    std::remove(path_.c_str());
    auto s = JobStore::Open(path_);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    store_ = std::move(*s);
    inputs_ = {JobInput{"L1.csv", Recording(1)}, JobInput{"L2.csv", Recording(2)}};
  }
  std::string path_;
  std::unique_ptr<JobStore> store_;
  std::array<JobInput, 2> inputs_;
};

TEST_F(JobsTest, OptionsRoundTripThroughJson) {
  JobOptions o = SmallOptions();
  o.estimate.eval.points = {2, 9};
  o.estimate.phase3.method = Phase3Method::kBobyqa;
  o.causal_filter = true;
  auto back = JobOptionsFromJson(o.ToJson());
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->ToJson(), o.ToJson());
  // Jobs stored before the knot rate existed still read (with their explicit step).
  std::string old = o.ToJson();
  const size_t at = old.find(",\"knot_rate\":");
  old.erase(at, old.find(',', at + 1) - at);
  auto legacy = JobOptionsFromJson(old);
  ASSERT_TRUE(legacy.ok()) << legacy.status().ToString() << "\n" << old;
  EXPECT_EQ(legacy->estimate.eval.knot_rate, EvaluationOptions().knot_rate);
  EXPECT_FALSE(JobOptionsFromJson("{\"eval\":3}").ok());
  EXPECT_FALSE(JobOptionsFromJson("not json").ok());
}

TEST_F(JobsTest, FinishedJobsWithFewerRefitsThanTodaysMinimumStayAnalysable) {
  JobOptions o = SmallOptions();
  o.bootstrap.replicates = MinReplicates(o.bootstrap.level) - 1;
  const auto run = JobOptionsFromJson(o.ToJson());
  EXPECT_EQ(run.status().code(), Status::Code::kInvalidArgument);
  EXPECT_NE(run.status().message().find("at least"), std::string::npos) << run.status().ToString();
  const auto analyse = JobOptionsFromJson(o.ToJson(), OptionsUse::kAnalyse);
  ASSERT_TRUE(analyse.ok()) << analyse.status().ToString();
  EXPECT_EQ(analyse->bootstrap.replicates, o.bootstrap.replicates);
}

// The options' canonical text is compared as text by the store (job reuse) and hashed
// into the evaluation key (evaluation reuse): a change to its bytes orphans every stored
// job and evaluation, so the text of the defaults is pinned here.
TEST(JobOptionsText, CanonicalTextOfTheDefaultsIsUnchanged) {
  JobOptions o;
  EXPECT_EQ(o.ToJson(),
            "{\"eval\":{\"points\":[3,7,10],\"t_max\":5,\"solver\":\"inertial\",\"eps\":0.0001,"
            "\"tolerance\":1e-08,\"substeps\":0,\"knot_rate\":600,\"restart_after_gaps\":false},"
            "\"screening_substeps\":0,\"n_max\":10,\"d_mu\":0.10000000000000001,\"d_eta\":0.001,\"d1\":1,"
            "\"d2\":0.20000000000000001,\"phase3\":\"grg\",\"fix_scale\":false,\"grg_max_iterations\":200,"
            "\"grg_gradient_tolerance\":1.0000000000000001e-05,\"fd_step\":0.0001,\"max_evaluations\":400,"
            "\"abandon\":true,\"lowpass_hz\":5,\"causal_filter\":false,\"smoothing\":\"auto\","
            "\"spline_order\":3,\"bootstrap_replicates\":20,\"bootstrap_level\":0.90000000000000002,"
            "\"bootstrap_seed\":1}");
  EXPECT_EQ(EvalKey({"a", "b"}, o), "3fa1bbae2f3c19be8c4e31831d6e14eb3f980824a4c5a9fc27fa3cc0bb4dc6ac");
  // The low-pass form and the optional restart interval.
  o.smoothing = SmoothingMethod::kLowpass;
  o.estimate.eval.restart_every = 0.5;
  EXPECT_EQ(o.ToJson(),
            "{\"eval\":{\"points\":[3,7,10],\"t_max\":5,\"solver\":\"inertial\",\"eps\":0.0001,"
            "\"tolerance\":1e-08,\"substeps\":0,\"knot_rate\":600,\"restart_after_gaps\":false,"
            "\"restart_every\":0.5},\"screening_substeps\":0,\"n_max\":10,\"d_mu\":0.10000000000000001,"
            "\"d_eta\":0.001,\"d1\":1,\"d2\":0.20000000000000001,\"phase3\":\"grg\",\"fix_scale\":false,"
            "\"grg_max_iterations\":200,\"grg_gradient_tolerance\":1.0000000000000001e-05,"
            "\"fd_step\":0.0001,\"max_evaluations\":400,\"abandon\":true,\"lowpass_hz\":5,"
            "\"causal_filter\":false,\"smoothing\":\"lowpass\",\"spline_order\":3,\"bootstrap_replicates\":20,"
            "\"bootstrap_level\":0.90000000000000002,\"bootstrap_seed\":1}");
  EXPECT_EQ(EvalKey({"a", "b"}, o), "2574e7da964ad5cf8c6c824f168c8e814f4b5d2f91fae14dbfed2763b516181a");
}

TEST_F(JobsTest, ResultCarriesSmoothingStillBodyAndIntervals) {
  JobOptions o = SmallOptions();
  o.smoothing = SmoothingMethod::kAuto;
  o.bootstrap.replicates = 19;
  o.estimate.eval.restart_every = 0.5;
  auto back = JobOptionsFromJson(o.ToJson());
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->ToJson(), o.ToJson());
  bool reused = false;
  auto id = SubmitEstimateJob(*store_, inputs_, o, false, &reused);
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  ASSERT_TRUE(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(2)).ok());
  auto job = store_->GetJob(*id);
  ASSERT_TRUE(job.ok());
  const auto r = nlohmann::json::parse(job->result_json);
  ASSERT_EQ(r["smoothing"].size(), 2u);
  EXPECT_EQ(r["smoothing"][0]["method"].get<std::string>().rfind("auto", 0), 0u);
  EXPECT_GT(r["still_body"]["E_mm"].get<double>(), r["estimate"]["E_mm"].get<double>());
  EXPECT_TRUE(r["explains_motion"].get<bool>());
  const auto& b = r["bootstrap"];
  EXPECT_EQ(b["replicates"].get<int>() + b["failed"].get<int>(), 19);
  EXPECT_EQ(b["fits"].size(), static_cast<size_t>(b["replicates"].get<int>()));
  // Clean data from the same model: the fit is right; a combination is either
  // determined with an interval that holds the truth or says why it is not.
  EXPECT_NEAR(b["K_mu"]["estimate"].get<double>(), kTruth.K_mu(), 0.01 * kTruth.K_mu());
  for (const char* k : {"K_mu", "K_eta", "v_c"}) {
    if (b[k]["determined"].get<bool>()) {
      const double truth = std::string(k) == "K_mu"    ? kTruth.K_mu()
                           : std::string(k) == "K_eta" ? kTruth.K_eta()
                                                       : kTruth.v_c();
      EXPECT_LE(b[k]["lo"].get<double>(), truth * 1.001) << k;
      EXPECT_GE(b[k]["hi"].get<double>(), truth / 1.001) << k;
    } else {
      EXPECT_FALSE(b[k]["why"].get<std::string>().empty()) << k;
    }
  }
}

TEST_F(JobsTest, BadInputStoresNothing) {
  bool reused = false;
  auto bad = inputs_;
  bad[1].content = "# fps: 100\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,oops,2,0\n";
  auto id = SubmitEstimateJob(*store_, bad, SmallOptions(), true, &reused);
  ASSERT_FALSE(id.ok());
  EXPECT_NE(id.status().message().find("L2.csv:3: column 5 (y1): not a number 'oops'"), std::string::npos)
      << id.status().message();
  JobOptions too_long = SmallOptions();
  too_long.estimate.eval.t_max = 3;
  EXPECT_FALSE(SubmitEstimateJob(*store_, inputs_, too_long, true, &reused).ok());
  JobOptions absurd = SmallOptions();
  absurd.estimate.search.n_max = 100;  // 101^4 sets
  EXPECT_EQ(SubmitEstimateJob(*store_, inputs_, absurd, true, &reused).status().code(),
            Status::Code::kResourceExhausted);
  auto jobs = store_->ListJobs();
  ASSERT_TRUE(jobs.ok());
  EXPECT_TRUE(jobs->empty());
}

TEST_F(JobsTest, RunsRecordsAndReuses) {
  bool reused = true;
  auto id = SubmitEstimateJob(*store_, inputs_, SmallOptions(), true, &reused);
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  EXPECT_FALSE(reused);
  std::vector<std::string> phases;
  JobHooks hooks;
  hooks.progress = [&](const std::string& p, int64_t, int64_t, double) {
    if (phases.empty() || phases.back() != p) phases.push_back(p);
  };
  ASSERT_TRUE(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(2), hooks).ok());
  EXPECT_EQ(phases.front(), "phase1");
  auto job = store_->GetJob(*id);
  ASSERT_TRUE(job.ok());
  EXPECT_EQ(job->state, JobState::kDone);
  EXPECT_NE(job->result_json.find("\"identifiability\""), std::string::npos);
  auto n1 = store_->CountEvaluations(*id, 1);
  ASSERT_TRUE(n1.ok());
  // Every Phase 1 set with an E is stored; the abandoned ones (no E) are only counted.
  const auto summary = nlohmann::json::parse(job->result_json)["phases"];
  EXPECT_GT(summary[0]["abandoned"].get<int64_t>(), 0);
  EXPECT_EQ(*n1 + summary[0]["abandoned"].get<int64_t>(), 256);
  auto stored = store_->Evaluations(*id, 1);
  ASSERT_TRUE(stored.ok());
  for (const auto& r : *stored) EXPECT_FALSE(std::isnan(r.e));
  auto s1 = store_->Survivors(*id, 1), s2 = store_->Survivors(*id, 2);
  ASSERT_TRUE(s1.ok() && s2.ok());
  EXPECT_EQ(s1->size(), 13u);  // 5 % of 256, rounded
  EXPECT_FALSE(s2->empty());
  // The best stored Phase 1 set is the first survivor.
  auto best = store_->Evaluations(*id, 1, 1);
  ASSERT_TRUE(best.ok());
  EXPECT_EQ((*best)[0].set, (*s1)[0].set);
  // The same inputs and options: the finished job is returned.
  auto again = SubmitEstimateJob(*store_, inputs_, SmallOptions(), true, &reused);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(reused);
  EXPECT_EQ(*again, *id);
  // Different Phase 3 options, same evaluation key: Phases 1–2 come from the store.
  JobOptions other = SmallOptions();
  other.estimate.phase3.method = Phase3Method::kNone;
  auto id2 = SubmitEstimateJob(*store_, inputs_, other, true, &reused);
  ASSERT_TRUE(id2.ok());
  EXPECT_FALSE(reused);
  ASSERT_TRUE(RunEstimateJob(*store_, *id2, LocalEvaluatorFactory(1)).ok());
  auto job2 = store_->GetJob(*id2);
  EXPECT_NE(job2->result_json.find("\"reused_evaluations\":"), std::string::npos);
  EXPECT_EQ(job2->result_json.find("\"reused_evaluations\":0"), std::string::npos);
}

TEST_F(JobsTest, InterruptedJobResumesFromStoredEvaluations) {
  bool reused = false;
  auto id = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(id.ok());
  // Interrupt as soon as Phase 2 starts, as a crash or Ctrl-C would.
  JobHooks stop;
  bool phase2 = false;
  stop.progress = [&](const std::string& p, int64_t, int64_t, double) { phase2 |= p == "phase2"; };
  stop.cancelled = [&] { return phase2; };
  EXPECT_EQ(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(1), stop).code(), Status::Code::kCancelled);
  EXPECT_EQ(store_->GetJob(*id)->state, JobState::kCancelled);
  auto stored1 = store_->CountEvaluations(*id, 1);
  ASSERT_TRUE(stored1.ok());
  // A coordinator restart resumes jobs that were running: put it back and run again.
  ASSERT_TRUE(store_->SetState(*id, JobState::kRunning).ok());
  ASSERT_TRUE(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(2)).ok());
  auto job = store_->GetJob(*id);
  EXPECT_EQ(job->state, JobState::kDone);
  // At least every Phase 1 E stored before the stop (abandoned sets have none).
  const size_t at = job->result_json.find("\"reused_evaluations\":");
  ASSERT_NE(at, std::string::npos);
  EXPECT_GE(std::stol(job->result_json.substr(at + 21)), *stored1);
  // …and its result equals an undisturbed run's.
  auto fresh = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(fresh.ok());
  auto path2 = path_ + ".fresh.db";
  std::remove(path2.c_str());
  auto other = JobStore::Open(path2);
  ASSERT_TRUE(other.ok());
  auto id3 = SubmitEstimateJob(**other, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(id3.ok());
  ASSERT_TRUE(RunEstimateJob(**other, *id3, LocalEvaluatorFactory(2)).ok());
  const std::string a = job->result_json, b = (*other)->GetJob(*id3)->result_json;
  // Compare the estimate block (timings and reuse counts differ) and the survivors.
  EXPECT_EQ(a.substr(0, a.find("\"phases\"")), b.substr(0, b.find("\"phases\"")));
  for (int phase : {1, 2}) {
    auto resumed = store_->Survivors(*id, phase), undisturbed = (*other)->Survivors(*id3, phase);
    ASSERT_TRUE(resumed.ok() && undisturbed.ok());
    ASSERT_EQ(resumed->size(), undisturbed->size());
    for (size_t i = 0; i < resumed->size(); ++i) {
      EXPECT_EQ((*resumed)[i].set, (*undisturbed)[i].set) << "phase " << phase << " rank " << i;
      EXPECT_EQ((*resumed)[i].e, (*undisturbed)[i].e) << "phase " << phase << " rank " << i;
    }
  }
}

// A failed or cancelled job's evaluations are never a source for another job (nor
// for a lookup): a new job with the same inputs and options evaluates everything
// itself. Once a job with the same key is done, its evaluations are reused.
TEST_F(JobsTest, EvaluationsOfFailedOrCancelledJobsAreNeverReused) {
  auto reused_count = [&](int64_t id) {
    const std::string r = store_->GetJob(id)->result_json;
    const size_t at = r.find("\"reused_evaluations\":");
    EXPECT_NE(at, std::string::npos) << r;
    return at == std::string::npos ? -1L : std::stol(r.substr(at + 21));
  };
  bool reused = false;
  std::vector<Coefficients> stored_sets;
  for (JobState end : {JobState::kCancelled, JobState::kFailed}) {
    auto id = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
    ASSERT_TRUE(id.ok());
    JobHooks stop;
    bool phase2 = false;
    stop.progress = [&](const std::string& p, int64_t, int64_t, double) { phase2 |= p == "phase2"; };
    stop.cancelled = [&] { return phase2; };
    EXPECT_EQ(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(1), stop).code(), Status::Code::kCancelled);
    ASSERT_TRUE(store_->SetState(*id, end, end == JobState::kFailed ? "a task was quarantined" : "").ok());
    auto evals = store_->Evaluations(*id, 1);
    ASSERT_TRUE(evals.ok());
    ASSERT_FALSE(evals->empty()) << "the interrupted job stored nothing";
    stored_sets.clear();
    for (const auto& r : *evals) stored_sets.push_back(r.set);
    std::vector<std::optional<double>> found;
    ASSERT_TRUE(store_->LookupEvaluations(store_->GetJob(*id)->eval_key, stored_sets, &found).ok());
    for (size_t i = 0; i < found.size(); ++i) EXPECT_FALSE(found[i].has_value()) << JobStateName(end) << " set " << i;
  }
  // A job reuses its own Phase 1 sets in Phase 2: as many as in a store of its own.
  const std::string alone_path = path_ + ".alone.db";
  std::remove(alone_path.c_str());
  auto alone = JobStore::Open(alone_path);
  ASSERT_TRUE(alone.ok());
  auto alone_id = SubmitEstimateJob(**alone, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(alone_id.ok());
  ASSERT_TRUE(RunEstimateJob(**alone, *alone_id, LocalEvaluatorFactory(2)).ok());
  const std::string r = (*alone)->GetJob(*alone_id)->result_json;
  const long own = std::stol(r.substr(r.find("\"reused_evaluations\":") + 21));
  auto fresh = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(fresh.ok());
  ASSERT_TRUE(RunEstimateJob(*store_, *fresh, LocalEvaluatorFactory(2)).ok());
  EXPECT_EQ(reused_count(*fresh), own);
  // A done job is a source.
  auto again = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
  ASSERT_TRUE(again.ok());
  ASSERT_TRUE(RunEstimateJob(*store_, *again, LocalEvaluatorFactory(2)).ok());
  EXPECT_GT(reused_count(*again), own);
  std::remove(alone_path.c_str());
}

TEST_F(JobsTest, FullGridStoresEveryEAndTheSameSurvivors) {
  JobOptions full = SmallOptions();
  full.estimate.search.abandon = false;
  bool reused = false;
  auto a = SubmitEstimateJob(*store_, inputs_, SmallOptions(), false, &reused);
  auto b = SubmitEstimateJob(*store_, inputs_, full, true, &reused);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE(*a, *b);  // a different job: the full grid is an option of its own
  ASSERT_TRUE(RunEstimateJob(*store_, *a, LocalEvaluatorFactory(2)).ok());
  ASSERT_TRUE(RunEstimateJob(*store_, *b, LocalEvaluatorFactory(2)).ok());
  EXPECT_EQ(*store_->CountEvaluations(*b, 1), 256);
  EXPECT_LT(*store_->CountEvaluations(*a, 1), 256);
  for (int phase : {1, 2}) {
    auto sa = store_->Survivors(*a, phase), sb = store_->Survivors(*b, phase);
    ASSERT_TRUE(sa.ok() && sb.ok());
    ASSERT_EQ(sa->size(), sb->size());
    for (size_t i = 0; i < sa->size(); ++i) {
      EXPECT_EQ((*sa)[i].set, (*sb)[i].set);
      EXPECT_EQ((*sa)[i].e, (*sb)[i].e);
    }
  }
  // Every E the abandoning job stored is the full grid's, bit for bit.
  auto ea = store_->Evaluations(*a, 1), eb = store_->Evaluations(*b, 1);
  ASSERT_TRUE(ea.ok() && eb.ok());
  std::map<std::array<double, 4>, double> by_set;
  for (const auto& r : *eb) by_set[r.set.AsArray()] = r.e;
  for (const auto& r : *ea) EXPECT_EQ(r.e, by_set.at(r.set.AsArray()));
}

}  // namespace
}  // namespace wormdrag
