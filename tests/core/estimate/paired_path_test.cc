// Early abandoning in the evaluation (paired_path.h): the cut, the threshold that
// proves a set out, and EvaluateLanes with a cut.
#include "core/estimate/paired_path.h"

#include <cmath>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

TEST(RunningCut, IsTheKeepThSmallestOfferedAndOnlyTightens) {
  RunningCut cut(3);
  EXPECT_EQ(cut.value(), INFINITY);
  cut.Offer(5);
  cut.Offer(INFINITY);    // unsimulable: ignored
  cut.Offer(kAbandoned);  // no E: ignored
  cut.Offer(7);
  EXPECT_EQ(cut.value(), INFINITY);  // two E known, three kept
  cut.Offer(6);
  EXPECT_EQ(cut.value(), 7);
  cut.Offer(9);
  EXPECT_EQ(cut.value(), 7);
  cut.Offer(1);
  EXPECT_EQ(cut.value(), 6);
  RunningCut sent(3, 4.5);  // a cut known from elsewhere (a worker's task)
  EXPECT_EQ(sent.value(), 4.5);
  for (double e : {1, 2, 3}) sent.Offer(e);
  EXPECT_EQ(sent.value(), 3);
}

TEST(RunningCut, ThreadsOfferingTogetherGetTheExactCut) {
  std::vector<double> all(4000);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (double& e : all) e = u(rng);
  RunningCut cut(40);
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&, t] {
      for (size_t i = t; i < all.size(); i += 4) cut.Offer(all[i]);
    });
  for (auto& th : pool) th.join();
  std::vector<double> sorted = all;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(cut.value(), sorted[39]);
}

TEST(AbandonThreshold, ASumAboveItProvesEAboveTheCut) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 100000; ++trial) {
    const double cut = std::ldexp(u(rng), static_cast<int>(u(rng) * 20) - 10);
    const int count = 1 + static_cast<int>(u(rng) * 20000);
    const double t = AbandonThreshold(cut, count);
    const double s = std::nextafter(t, INFINITY);  // the smallest sum that abandons
    ASSERT_GT(s / count, cut) << "cut " << cut << " count " << count;
    ASSERT_LE(t, cut * count * (1 + 1e-14));  // and it gives away almost nothing
  }
  EXPECT_EQ(AbandonThreshold(INFINITY, 10), INFINITY);
}

Kinematics Loco(int index, double duration) {
  RecordingSpec spec;
  spec.fps = 100;
  spec.duration = duration;
  auto k = GenerateRecording(Locomotion(index), {0.55, 0.25, 0.006, 0.003}, SimOptions(), spec);
  EXPECT_TRUE(k.ok());
  return *k;
}

TEST(EvaluateLanes, ACutStopsOnlySetsProvenWorseAndKeepsTheOthersExact) {
  EvaluationOptions eo;
  eo.t_max = 2;
  auto pair = PairedPath::Create({Loco(1, 2), Loco(2, 2)}, {"L1", "L2"}, eo);
  ASSERT_TRUE(pair.ok()) << pair.status().ToString();
  // Eight sets from near the truth to far from it.
  const Coefficients sets[kLanes] = {{0.55, 0.25, 0.006, 0.003}, {0.5, 0.25, 0.006, 0.003}, {0.6, 0.2, 0.005, 0.003},
                                     {0.2, 0.6, 0.001, 0.008},   {0.9, 0.1, 0.01, 0.001},   {0.3, 0.3, 0.003, 0.003},
                                     {0.1, 0.8, 0.0, 0.01},      {0.7, 0.4, 0.008, 0.001}};
  EvaluationWorkspace ws;
  double exact[kLanes], cut_e[kLanes];
  const int64_t full = EvaluateLanes(**pair, sets, kLanes, Objective::kMeanDistance, ws, exact);
  EXPECT_EQ(full, kLanes * (*pair)->knots_per_set());
  // No cut yet (+inf): nothing stops, same bits.
  RunningCut open(1);
  EvaluateLanes(**pair, sets, kLanes, Objective::kMeanDistance, ws, cut_e, &open);
  for (int i = 0; i < kLanes; ++i) EXPECT_EQ(cut_e[i], exact[i]) << i;
  // A cut between the values: every set above it may stop (and those far above do),
  // every set at or below it keeps its exact E.
  std::vector<double> sorted(exact, exact + kLanes);
  std::sort(sorted.begin(), sorted.end());
  RunningCut cut(1, sorted[2]);
  const int64_t knots = EvaluateLanes(**pair, sets, kLanes, Objective::kMeanDistance, ws, cut_e, &cut);
  int stopped = 0;
  for (int i = 0; i < kLanes; ++i) {
    if (IsAbandoned(cut_e[i])) {
      ++stopped;
      EXPECT_GT(exact[i], sorted[2]) << i;
    } else {
      EXPECT_EQ(cut_e[i], exact[i]) << i;
    }
    if (exact[i] <= sorted[2]) { EXPECT_EQ(cut_e[i], exact[i]) << i; }
  }
  EXPECT_GT(stopped, 0);
  // The three kept sets run to the end against worm 0, so does the batch; against
  // worm 1 only the sets not yet stopped run.
  const int64_t worm0 = static_cast<int64_t>((*pair)->worm(0).drive.knots().size());
  EXPECT_GE(knots, kLanes * worm0);
  EXPECT_LE(knots, full);
  // Only sets far worse than the cut in one batch: it ends early.
  const Coefficients bad[2] = {sets[3], sets[6]};
  double bad_e[2];
  const int64_t short_run = EvaluateLanes(**pair, bad, 2, Objective::kMeanDistance, ws, bad_e, &cut);
  EXPECT_TRUE(IsAbandoned(bad_e[0]) && IsAbandoned(bad_e[1]));
  EXPECT_LT(short_run, 2 * (*pair)->knots_per_set());
}

TEST(EvaluateLanes, EachSetStopsOnlyAboveItsOwnCutForEitherObjective) {
  EvaluationOptions eo;
  eo.t_max = 1;
  auto pair = PairedPath::Create({Loco(1, 1), Loco(2, 1)}, {"L1", "L2"}, eo);
  ASSERT_TRUE(pair.ok()) << pair.status().ToString();
  const Coefficients sets[kLanes] = {{0.55, 0.25, 0.006, 0.003}, {0.5, 0.25, 0.006, 0.003}, {0.6, 0.2, 0.005, 0.003},
                                     {0.2, 0.6, 0.001, 0.008},   {0.9, 0.1, 0.01, 0.001},   {0.3, 0.3, 0.003, 0.003},
                                     {0.1, 0.8, 0.0, 0.01},      {0.7, 0.4, 0.008, 0.001}};
  for (Objective objective : {Objective::kMeanDistance, Objective::kMeanSquaredDistance}) {
    EvaluationWorkspace ws;
    double exact[kLanes], e[kLanes];
    EvaluateLanes(**pair, sets, kLanes, objective, ws, exact);
    // Lanes 0–3 share a cut at their second smallest value, lanes 4–7 have none yet.
    std::vector<double> first(exact, exact + 4);
    std::sort(first.begin(), first.end());
    RunningCut tight(1, first[1]), open(1);
    const RunningCut* cuts[kLanes] = {&tight, &tight, &tight, &tight, &open, &open, &open, &open};
    EvaluateLanes(**pair, sets, kLanes, objective, ws, e, cuts);
    int stopped = 0;
    for (int i = 0; i < kLanes; ++i) {
      if (IsAbandoned(e[i])) {
        ++stopped;
        EXPECT_LT(i, 4);
        EXPECT_GT(exact[i], first[1]) << i;
      } else {
        EXPECT_EQ(e[i], exact[i]) << i;  // the same bits as without cuts
      }
    }
    EXPECT_GT(stopped, 0);
  }
}

TEST(LocalEvaluator, OffersItsEToTheCutAndCountsKnots) {
  EvaluationOptions eo;
  eo.t_max = 1;
  auto pair = PairedPath::Create({Loco(1, 1), Loco(2, 1)}, {"L1", "L2"}, eo);
  ASSERT_TRUE(pair.ok());
  std::vector<Coefficients> sets;
  for (int i = 0; i < 40; ++i) sets.push_back({0.05 * (i % 10), 0.1 * (i / 10) + 0.1, 0.001 * (i % 7), 0.002});
  LocalEvaluator ev(*pair, 2);
  std::vector<double> exact, e;
  ASSERT_TRUE(ev.Evaluate(sets, &exact).ok());
  RunningCut cut(5);
  KnotCount knots;
  EvaluationRequest req;
  req.cut = &cut;
  req.knots = &knots;
  ASSERT_TRUE(ev.Evaluate(sets, &e, req).ok());
  std::vector<double> finite;
  for (size_t i = 0; i < sets.size(); ++i) {
    if (!IsAbandoned(e[i])) { EXPECT_EQ(e[i], exact[i]) << i; }
    if (std::isfinite(exact[i])) finite.push_back(exact[i]);
  }
  std::sort(finite.begin(), finite.end());
  EXPECT_EQ(cut.value(), finite[4]);  // every exact E was offered: the cut is exact at the end
  EXPECT_EQ(knots.full.load(), 40 * (*pair)->knots_per_set());
  EXPECT_LE(knots.simulated.load(), knots.full.load());
}

TEST(LocalEvaluator, SetCutsKeepEveryValueExactInSmallAndLargeBatches) {
  EvaluationOptions eo;
  eo.t_max = 1;
  auto pair = PairedPath::Create({Loco(1, 1), Loco(2, 1)}, {"L1", "L2"}, eo);
  ASSERT_TRUE(pair.ok());
  LocalEvaluator ev(*pair, 2);
  // 6 sets (fewer chunks than threads: each chunk's worms on two threads) and 30.
  for (int n : {6, 30}) {
    std::vector<Coefficients> sets;
    for (int i = 0; i < n; ++i) sets.push_back({0.05 * (i % 10) + 0.05, 0.1 * (i / 10) + 0.1, 0.001 * (i % 7), 0.002});
    EvaluationRequest msd;
    msd.objective = Objective::kMeanSquaredDistance;
    std::vector<double> exact, e;
    ASSERT_TRUE(ev.Evaluate(sets, &exact, msd).ok());
    // Two groups, alternating; each group's cut starts at its third set's value.
    RunningCut a(1, exact[2]), b(1, exact[3]);
    EvaluationRequest req = msd;
    for (int i = 0; i < n; ++i) req.set_cuts.push_back(i % 2 ? &b : &a);
    ASSERT_TRUE(ev.Evaluate(sets, &e, req).ok());
    double best[2] = {INFINITY, INFINITY};
    for (int i = 0; i < n; ++i) best[i % 2] = std::min(best[i % 2], exact[i]);
    int stopped = 0;
    for (int i = 0; i < n; ++i) {
      if (IsAbandoned(e[i])) {  // never a group's best
        ++stopped;
        EXPECT_GT(exact[i], best[i % 2]) << n << " sets, set " << i;
      } else {
        EXPECT_EQ(e[i], exact[i]) << n << " sets, set " << i;
      }
    }
    EXPECT_GT(stopped, 0) << n;
    EXPECT_EQ(a.value(), best[0]);  // each group's best reached its own cut
    EXPECT_EQ(b.value(), best[1]);
    req.set_cuts.pop_back();  // one cut short: refused, not read past its end
    EXPECT_EQ(ev.Evaluate(sets, &e, req).code(), Status::Code::kInvalidArgument);
    req.set_cuts.push_back(nullptr);
    EXPECT_EQ(ev.Evaluate(sets, &e, req).code(), Status::Code::kInvalidArgument);
  }
}

}  // namespace
}  // namespace wormdrag
