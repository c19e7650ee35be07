#include "server/remote_evaluator.h"

#include <gtest/gtest.h>

#include <numeric>

#include "core/sim/pattern.h"

namespace wormdrag::server {
namespace {

size_t Sum(const std::vector<size_t>& v) {
  return std::accumulate(v.begin(), v.end(), size_t{0});
}

// Each task must start on a lane-group boundary of the call (bit-identity with an
// embedded run) and be at most chunk_sets long.
void ExpectWholeGroups(const std::vector<size_t>& sizes, size_t n, int chunk) {
  ASSERT_EQ(Sum(sizes), n);
  for (size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_GT(sizes[i], 0u);
    EXPECT_LE(sizes[i], static_cast<size_t>(chunk));
    if (i + 1 < sizes.size()) { EXPECT_EQ(sizes[i] % kLanes, 0u) << "task " << i; }
  }
}

TEST(TaskSizes, FullBatchesKeepTheChunkSize) {
  const auto s = TaskSizes(512, 32, 2);
  ExpectWholeGroups(s, 512, 32);
  EXPECT_EQ(s, std::vector<size_t>(16, 32));
  EXPECT_EQ(TaskSizes(512, 32, 1), std::vector<size_t>(16, 32));
}

TEST(TaskSizes, SmallBatchesAreSharedEvenlyByTheWorkers) {
  // A GRG round of 11 starts × 9 stencil points: 13 lane groups. Cut at the chunk
  // (4+4+4+1 groups) one worker would run 9 groups while the other ran 4.
  const auto s = TaskSizes(99, 32, 2);
  ExpectWholeGroups(s, 99, 32);
  EXPECT_EQ(s, (std::vector<size_t>{32, 24, 24, 19}));
  // Fewer groups than workers: one group each.
  EXPECT_EQ(TaskSizes(20, 32, 4), (std::vector<size_t>{8, 8, 4}));
  // Three workers, 9 groups: three tasks of three groups.
  EXPECT_EQ(TaskSizes(66, 32, 3), (std::vector<size_t>{24, 24, 18}));
}

TEST(TaskSizes, NoWorkersYetMeansOneAndEmptyMeansNoTask) {
  EXPECT_EQ(TaskSizes(99, 32, 0), TaskSizes(99, 32, 1));
  EXPECT_EQ(TaskSizes(99, 32, 1), (std::vector<size_t>{32, 24, 24, 19}));
  EXPECT_TRUE(TaskSizes(0, 32, 2).empty());
  EXPECT_EQ(TaskSizes(3, 32, 2), (std::vector<size_t>{3}));
}

TEST(TaskSizes, EveryCutIsWholeLaneGroups) {
  for (size_t n = 1; n < 600; n += 7)
    for (int chunk : {8, 32, 128})
      for (int w : {1, 2, 3, 5, 16}) ExpectWholeGroups(TaskSizes(n, chunk, w), n, chunk);
}

TEST(SplitByWorm, OnlyCallsWithFewerLaneGroupsThanWorkersAndNoCut) {
  EXPECT_TRUE(SplitByWorm(1, 2, false));
  EXPECT_TRUE(SplitByWorm(8, 2, false));
  EXPECT_FALSE(SplitByWorm(9, 2, false)) << "two groups already keep two workers busy";
  EXPECT_TRUE(SplitByWorm(16, 3, false));
  EXPECT_FALSE(SplitByWorm(8, 2, true)) << "a share's sum cannot be abandoned against the call's cut";
  EXPECT_FALSE(SplitByWorm(8, 1, false));
  EXPECT_FALSE(SplitByWorm(8, 0, false));
  EXPECT_FALSE(SplitByWorm(0, 2, false));
}

TEST(GroupCuts, EachSetPointsAtItsGroupsFirstSetAndCarriesItsCutNow) {
  RunningCut ray_a(1, 0.5), ray_b(1);
  RunningCut* cuts[] = {&ray_b, &ray_a, &ray_b, &ray_a, &ray_a};
  std::vector<double> values;
  std::vector<int32_t> groups;
  GroupCuts(cuts, 5, &values, &groups);
  EXPECT_EQ(groups, (std::vector<int32_t>{0, 1, 0, 1, 1}));
  EXPECT_EQ(values, (std::vector<double>{INFINITY, 0.5, INFINITY, 0.5, 0.5}));
  ray_b.Offer(0.25);
  GroupCuts(cuts + 2, 3, &values, &groups);  // a task starting at the call's third set
  EXPECT_EQ(groups, (std::vector<int32_t>{0, 1, 1}));
  EXPECT_EQ(values, (std::vector<double>{0.25, 0.5, 0.5}));
}

std::shared_ptr<const PairedPath> SmallPair() {
  EvaluationOptions e;
  e.t_max = 0.5;
  std::array<Kinematics, 2> k;
  for (int j = 0; j < 2; ++j) {
    RecordingSpec spec;
    spec.fps = 60;
    spec.duration = 0.5;
    auto r = GenerateRecording(Locomotion(j + 1), {0.5, 0.2, 0.005, 0.002}, SimOptions(), spec);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    k[j] = *r;
  }
  auto p = PairedPath::Create(k, {"L1", "L2"}, e);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return *p;
}

// A worm's share as a worker reports it (worker/task_runner.cc, RunWormShare).
TaskResult Share(LocalEvaluator& ev, const std::vector<Coefficients>& sets, int worm, TaskKind kind) {
  const LaneOutput what = kind == TaskKind::kResiduals           ? LaneOutput::kResiduals
                          : kind == TaskKind::kResidualJacobians ? LaneOutput::kJacobians
                                                                 : LaneOutput::kSums;
  std::vector<WormLanes> chunks;
  ev.EvaluateWorm(sets, worm, what, &chunks);
  EXPECT_EQ(chunks.size(), 1u);
  TaskResult r;
  r.knots = r.knots_full = chunks[0].knots;
  for (size_t i = 0; i < sets.size(); ++i) {
    if (what == LaneOutput::kSums) {
      r.values.push_back(kind == TaskKind::kMeanDistance ? chunks[0].sum[i] : chunks[0].sum_sq[i]);
      continue;
    }
    r.residuals.push_back(chunks[0].residuals[i]);
    r.jacobians.push_back(chunks[0].jacobian[i]);
  }
  return r;
}

// The coordinator's combination of two worm tasks gives the bits one task gives, for
// every kind that is split (the service's results stay those of an embedded run).
TEST(CombineWormShares, GivesTheBitsOfOneTask) {
  auto pair = SmallPair();
  LocalEvaluator ev(pair, 1);
  const std::vector<Coefficients> sets = {
      {0.5, 0.2, 0.005, 0.002}, {0.7, 0.1, 0.004, 0.003}, {0.2, 0.6, 0.008, 0.001}, {1.1, 0.3, 0.002, 0.002}};
  for (TaskKind kind : {TaskKind::kMeanDistance, TaskKind::kMeanSquaredDistance}) {
    std::vector<double> whole;
    EvaluationRequest req;
    req.objective = kind == TaskKind::kMeanDistance ? Objective::kMeanDistance : Objective::kMeanSquaredDistance;
    ASSERT_TRUE(ev.Evaluate(sets, &whole, req).ok());
    const TaskResult c = CombineWormShares(*pair, kind, 4, Share(ev, sets, 0, kind), Share(ev, sets, 1, kind));
    ASSERT_EQ(c.values.size(), whole.size());
    for (size_t i = 0; i < whole.size(); ++i) EXPECT_EQ(c.values[i], whole[i]) << "set " << i;
    EXPECT_GT(c.knots, 0);
  }
  std::vector<std::vector<double>> r, jac;
  ASSERT_TRUE(ev.EvaluateResidualJacobians(sets, &r, &jac).ok());
  TaskResult c = CombineWormShares(*pair, TaskKind::kResidualJacobians, 4,
                                   Share(ev, sets, 0, TaskKind::kResidualJacobians),
                                   Share(ev, sets, 1, TaskKind::kResidualJacobians));
  EXPECT_EQ(c.residuals, r);
  EXPECT_EQ(c.jacobians, jac);
  std::vector<std::vector<double>> plain;
  ASSERT_TRUE(ev.EvaluateResiduals(sets, &plain).ok());
  c = CombineWormShares(*pair, TaskKind::kResiduals, 4, Share(ev, sets, 0, TaskKind::kResiduals),
                        Share(ev, sets, 1, TaskKind::kResiduals));
  EXPECT_EQ(c.residuals, plain);
  EXPECT_TRUE(c.jacobians.empty());
  // A set one worm cannot simulate has no residuals, as in one task.
  TaskResult failed = Share(ev, sets, 1, TaskKind::kResiduals);
  failed.residuals[2].clear();
  c = CombineWormShares(*pair, TaskKind::kResiduals, 4, Share(ev, sets, 0, TaskKind::kResiduals), std::move(failed));
  EXPECT_TRUE(c.residuals[2].empty());
  EXPECT_EQ(c.residuals[1], plain[1]);
}

}  // namespace
}  // namespace wormdrag::server
