#include "core/jobs/bootstrap_run.h"

#include <array>
#include <cstdio>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

const Coefficients kFit{0.0036, 0.0012, 0.004, 0.002};  // v_c 0.6 mm/s: both parts count

std::shared_ptr<const PairedPath> Pair() {
  RecordingSpec spec;
  spec.fps = 100;
  spec.duration = 1;
  std::array<Kinematics, 2> k;
  for (int w = 0; w < 2; ++w) k[w] = *GenerateRecording(Locomotion(w + 1), kFit, SimOptions{}, spec);
  EvaluationOptions o;
  o.t_max = 1;
  return *PairedPath::Create(k, {"a", "b"}, o);
}

// The decision logic of RunBootstrap with scripted refits: the basic replicates
// scatter 1 % around the fit (v_c exactly in place); the check's refits either follow
// the values they were made with (`follow` = 1: the data tell it apart) or land where
// the basic ones did (`follow` = 0: replicates made 1.5 times away refit to this fit).
// `smoothing_k_mu`: where refits of the data smoothed with λ ÷ and × 10 put K_μ, as
// multiples of the fit's (0: no smoothing check).
// `progress_seen`: every (done, total) RunBootstrap reports.
// Each refit's E lies in 0.008 … 0.0118 mm; `data_e` is the data's. `follow_v_c`:
// as `follow`, for v_c alone (< 0: the same). `check_gain` multiplies the ratios the
// check's refits land on (≠ 1: the estimator's bias there differs from the fit's).
BootstrapReport Scripted(double follow, std::vector<ReplicateTask>* seen, std::array<double, 2> smoothing_k_mu = {0, 0},
                         std::vector<std::pair<int, int>>* progress_seen = nullptr, double data_e = 0.01,
                         double follow_v_c = -1, double check_gain = 1) {
  if (follow_v_c < 0) follow_v_c = follow;
  ReplicateRunner scripted = [&](const PairedPath&, const std::vector<ReplicateTask>& tasks, const JobOptions&,
                                 const std::function<void(int, int)>& progress,
                                 const std::function<bool()>&) -> Result<std::vector<std::optional<ScoredSet>>> {
    std::vector<std::optional<ScoredSet>> out;
    for (const ReplicateTask& t : tasks) {
      seen->push_back(t);
      if (progress) progress(static_cast<int>(out.size()) + 1, static_cast<int>(tasks.size()));
      const Coefficients made = t.model ? *t.model : t.estimate.set;
      Coefficients c = kFit;
      if (t.refit_data) {
        c.mu_n *= t.smoothing_scale > 1 ? smoothing_k_mu[1] : smoothing_k_mu[0];
        out.push_back(ScoredSet{c, data_e});
        continue;
      }
      const double wiggle = 1 + 0.01 * ((t.index % 7) - 3) / 3.0;
      c.mu_t = kFit.eta_t * (kFit.v_c() + follow_v_c * (made.v_c() - kFit.v_c()));
      c.mu_n = c.mu_t * (kFit.K_mu() + follow * (made.K_mu() - kFit.K_mu())) * wiggle;
      c.eta_n = kFit.eta_t * (kFit.K_eta() + follow * (made.K_eta() - kFit.K_eta())) * wiggle;
      if (t.model) c.mu_n *= check_gain, c.eta_n *= check_gain;
      out.push_back(ScoredSet{c, 0.008 + 0.0002 * (t.index % 20)});
    }
    return out;
  };
  JobOptions o;
  o.bootstrap.replicates = 20;
  auto pair = Pair();
  const DataAtSmoothing data = [&](double) -> Result<std::shared_ptr<const PairedPath>> { return pair; };
  auto r = RunBootstrap(*pair, {kFit, data_e}, {0.005, 0.005}, o, scripted,
                        smoothing_k_mu[0] > 0 ? data : DataAtSmoothing(), [&](int done, int total) {
                          if (progress_seen) progress_seen->push_back({done, total});
                        });
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return *r;
}

TEST(RunBootstrap, ChecksDeterminedCombinationsAgainstReplicatesMadeAway) {
  std::vector<ReplicateTask> seen;
  BootstrapReport told = Scripted(1.0, &seen);
  EXPECT_TRUE(told.K_mu.determined) << told.K_mu.why;
  EXPECT_TRUE(told.K_eta.determined) << told.K_eta.why;
  // 20 basic refits, then 8 at each of ×1.5 and ÷1.5 of every determined combination.
  int made_away = 0;
  for (const ReplicateTask& t : seen) {
    EXPECT_EQ(t.estimate.set.mu_n, kFit.mu_n);  // every refit starts at the fit
    made_away += t.model.has_value();
  }
  EXPECT_EQ(made_away, told.check_refits);
  EXPECT_GE(told.check_refits, 2 * 2 * 8);

  seen.clear();
  BootstrapReport blind = Scripted(0.0, &seen);
  EXPECT_FALSE(blind.K_mu.determined);
  EXPECT_NE(blind.K_mu.why.find("do not tell them apart"), std::string::npos) << blind.K_mu.why;
  EXPECT_FALSE(blind.K_eta.determined);
}

// The estimator's response is monotone: replicates made 1.5 times below the corrected
// value that all refit above the data's fit say the truth lies lower still (decision
// 0048), and those made above that all refit below it say it lies higher.
TEST(RunBootstrap, WithholdsACombinationWhoseMadeAwayReplicatesRefitBeyondTheFit) {
  std::vector<ReplicateTask> seen;
  BootstrapReport over = Scripted(1.0, &seen, {0, 0}, nullptr, 0.01, -1, /*check_gain=*/1.6);
  EXPECT_FALSE(over.K_mu.determined);
  EXPECT_NE(over.K_mu.why.find("all above this fit"), std::string::npos) << over.K_mu.why;
  EXPECT_NE(over.K_mu.why.find("overshoots"), std::string::npos) << over.K_mu.why;
  BootstrapReport under = Scripted(1.0, &seen, {0, 0}, nullptr, 0.01, -1, /*check_gain=*/1 / 1.6);
  EXPECT_FALSE(under.K_eta.determined);
  EXPECT_NE(under.K_eta.why.find("all below this fit"), std::string::npos) << under.K_eta.why;
  // Every group of the check is recorded, with the range of its refits.
  ASSERT_GE(over.checks.size(), 4u);
  for (const auto& g : over.checks) EXPECT_LE(g.lo, g.hi) << g.name;
  EXPECT_EQ(over.ToJson()["checks"].size(), over.checks.size());
  // A gain within the refits' reach leaves the fit between the groups: still determined.
  BootstrapReport near = Scripted(1.0, &seen, {0, 0}, nullptr, 0.01, -1, /*check_gain=*/1.2);
  EXPECT_TRUE(near.K_mu.determined) << near.K_mu.why;
}

// v_c 0.6 mm/s divides the drag between the parts: when the check leaves v_c not
// determined, the ratios, each of one part, are withheld with it.
TEST(RunBootstrap, WithholdsTheRatiosWhenTheCrossoverSpeedIsNotDetermined) {
  std::vector<ReplicateTask> seen;
  BootstrapReport r = Scripted(1.0, &seen, {0, 0}, nullptr, 0.01, /*follow_v_c=*/0.0);
  EXPECT_FALSE(r.v_c.determined);
  EXPECT_NE(r.v_c.why.find("do not tell them apart"), std::string::npos) << r.v_c.why;
  for (const CombinationInterval* c : {&r.K_mu, &r.K_eta}) {
    EXPECT_FALSE(c->determined) << c->name;
    EXPECT_NE(c->why.find("crossover speed v_c"), std::string::npos) << c->name << ": " << c->why;
  }
}

// A data E above every refit's: part of the misfit is not tracking noise, so the
// replicates' intervals are not reported as determined, and no check refit is spent.
TEST(RunBootstrap, WithholdsEveryCombinationWhenTheDataMisfitMoreThanEveryRefit) {
  std::vector<ReplicateTask> seen;
  BootstrapReport inside = Scripted(1.0, &seen, {0, 0}, nullptr, 0.0117);
  EXPECT_TRUE(inside.misfit_explained);
  EXPECT_TRUE(inside.K_mu.determined) << inside.K_mu.why;
  EXPECT_EQ(inside.fit_e.size(), 20u);
  seen.clear();
  BootstrapReport above = Scripted(1.0, &seen, {0, 0}, nullptr, 0.0119);
  EXPECT_FALSE(above.misfit_explained);
  EXPECT_EQ(above.data_e, 0.0119);
  for (const CombinationInterval* c : {&above.K_mu, &above.K_eta, &above.v_c, &above.scale}) {
    EXPECT_FALSE(c->determined) << c->name;
    EXPECT_NE(c->why.find("not tracking noise"), std::string::npos) << c->name << ": " << c->why;
  }
  EXPECT_EQ(above.check_refits, 0);
  EXPECT_EQ(seen.size(), 20u);
  const Json j = above.ToJson();
  EXPECT_EQ(j["misfit_explained"], false);
  EXPECT_EQ(j["refit_E_mm"].size(), 20u);
}

// The progress counts the replicates, the smoothing check's refits and the check's,
// in one count that never falls and ends at all of them.
TEST(RunBootstrap, ProgressCountsEveryRefitOnce) {
  std::vector<ReplicateTask> seen;
  std::vector<std::pair<int, int>> progress;
  BootstrapReport r = Scripted(1.0, &seen, {1 / 1.1, 1.1}, &progress);
  ASSERT_GT(r.check_refits, 0);
  ASSERT_FALSE(progress.empty());
  for (size_t i = 1; i < progress.size(); ++i) {
    EXPECT_GE(progress[i].first, progress[i - 1].first) << i;
    EXPECT_GE(progress[i].second, progress[i - 1].second) << i;
    EXPECT_LE(progress[i].first, progress[i].second) << i;
  }
  const int all = static_cast<int>(seen.size());
  EXPECT_EQ(all, 20 + 2 + r.check_refits);
  EXPECT_EQ(progress.back(), std::make_pair(all, all));
}

TEST(RunBootstrap, WidensOrWithholdsACombinationThatMovesWithTheSmoothing) {
  std::vector<ReplicateTask> seen;
  // K_μ moves × and ÷ 1.6 with a decade of λ either way: its interval, widened to hold
  // both refits, spans 2.56 > 2. K_η stays.
  BootstrapReport moved = Scripted(1.0, &seen, {1 / 1.6, 1.6});
  EXPECT_FALSE(moved.K_mu.determined);
  EXPECT_NE(moved.K_mu.why.find("smoothed 10 times less and more"), std::string::npos) << moved.K_mu.why;
  EXPECT_TRUE(moved.K_eta.determined) << moved.K_eta.why;
  ASSERT_EQ(moved.smoothing_fits.size(), 2u);
  EXPECT_DOUBLE_EQ(moved.smoothing_fits[0].first, 0.1);
  EXPECT_DOUBLE_EQ(moved.smoothing_fits[1].first, 10);
  int data_refits = 0;
  for (const ReplicateTask& t : seen) {
    data_refits += t.refit_data;
    // Every task is one a worker accepts.
    EXPECT_TRUE(ReplicateTaskFromJson(ReplicateTaskToJson(t)).ok()) << ReplicateTaskToJson(t);
  }
  EXPECT_EQ(data_refits, 2);
  // A combination that moves 10 % stays determined, its interval widened to hold both refits.
  seen.clear();
  BootstrapReport widened = Scripted(1.0, &seen, {1 / 1.1, 1.1});
  EXPECT_TRUE(widened.K_mu.determined) << widened.K_mu.why;
  const double shift = widened.K_mu.corrected / widened.K_mu.estimate;
  EXPECT_LE(widened.K_mu.lo, kFit.K_mu() / 1.1 * shift * (1 + 1e-12));
  EXPECT_GE(widened.K_mu.hi, kFit.K_mu() * 1.1 * shift * (1 - 1e-12));
}

// Refits that both move K_μ up (as on agar-like data, where too little smoothing leaves
// noise and too much removes shape) also widen the interval below the fit, by their
// mirror image: 1.3 either way stays determined, 1.5 either way spans 2.25 > 2.
TEST(RunBootstrap, RefitsThatMoveOneWayWidenTheIntervalBothWays) {
  std::vector<ReplicateTask> seen;
  BootstrapReport up = Scripted(1.0, &seen, {1.3, 1.25});
  ASSERT_TRUE(up.K_mu.determined) << up.K_mu.why;
  EXPECT_LE(up.K_mu.lo, up.K_mu.corrected / 1.3 * (1 + 1e-12));
  EXPECT_GE(up.K_mu.hi, up.K_mu.corrected * 1.3 * (1 - 1e-12));
  seen.clear();
  BootstrapReport far = Scripted(1.0, &seen, {1.5, 1.2});
  EXPECT_FALSE(far.K_mu.determined);
  EXPECT_NE(far.K_mu.why.find("smoothed 10 times less and more"), std::string::npos) << far.K_mu.why;
  EXPECT_TRUE(far.K_eta.determined) << far.K_eta.why;
}

// A refit gives the same answer, to the bit, on one thread or on two (a worker gives a
// refit all of its cores; a job gives each of its side-by-side refits one).
TEST(FitReplicate, AnswerDoesNotDependOnTheThreads) {
  auto pair = Pair();
  JobOptions o;
  const ReplicateTask t{3, {kFit, 0.01}, std::nullopt, {0.005, 0.005}};
  PhaseSummary s1, s2;
  auto one = FitReplicate(*pair, t, o, &s1, 1), two = FitReplicate(*pair, t, o, &s2, 2);
  ASSERT_TRUE(one.ok()) << one.status().ToString();
  ASSERT_TRUE(two.ok()) << two.status().ToString();
  EXPECT_EQ(one->set.AsArray(), two->set.AsArray());
  EXPECT_EQ(one->e, two->e);
  EXPECT_EQ(s1.sets, s2.sets);
}

// A refit is bounded in scale as the data's fit is: started where the relaxation time
// outlasts a frame interval, it ends within one.
TEST(FitReplicate, RefitIsBoundedInScaleAsTheDataFit) {
  auto pair = Pair();
  const Coefficients slow = kFit.Scaled(1e-3);
  const RecordingFacts facts = FactsOf(*pair);
  ASSERT_GT(RelaxationTime(slow, facts.link_speed), 5 * facts.frame_interval);
  const ReplicateTask t{1, {slow, 0.01}, kFit, {0.005, 0.005}};  // made at the physical scale
  PhaseSummary free_fit;
  auto fit = FitReplicate(*pair, t, JobOptions(), &free_fit);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  std::printf("refit %s, relaxation time %.3g s, frame interval %.3g s\n", fit->set.ToString().c_str(),
              RelaxationTime(fit->set, facts.link_speed), facts.frame_interval);
  EXPECT_LE(RelaxationTime(fit->set, facts.link_speed), 1.05 * facts.frame_interval);
}

TEST(RunBootstrap, TasksRoundTripThroughJson) {
  ReplicateTask t{12, {kFit, 0.02}, Coefficients{1, 0.1, 0.01, 0.002}, {0.004, 0.005}};
  auto back = ReplicateTaskFromJson(ReplicateTaskToJson(t));
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->index, 12);
  ASSERT_TRUE(back->model.has_value());
  EXPECT_EQ(back->model->mu_n, 1);
  EXPECT_EQ(back->estimate.set.eta_t, kFit.eta_t);
  t.model.reset();
  back = ReplicateTaskFromJson(ReplicateTaskToJson(t));
  ASSERT_TRUE(back.ok());
  EXPECT_FALSE(back->model.has_value());
  EXPECT_FALSE(back->refit_data);
  t.refit_data = true;
  t.smoothing_scale = 0.1;
  back = ReplicateTaskFromJson(ReplicateTaskToJson(t));
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(back->refit_data);
  EXPECT_DOUBLE_EQ(back->smoothing_scale, 0.1);
  EXPECT_FALSE(ReplicateTaskFromJson("{\"index\":1,\"estimate\":[1,1,1,1],\"E\":0,\"noise_mm\":[0,0],"
                                     "\"refit_data\":true,\"smoothing_scale\":0}")
                   .ok());
  EXPECT_FALSE(ReplicateTaskFromJson("{\"index\":1,\"estimate\":[1,1,1,1],\"E\":0,\"noise_mm\":[0,0],"
                                     "\"model\":[1,-1,1,1]}")
                   .ok());
}

}  // namespace
}  // namespace wormdrag
