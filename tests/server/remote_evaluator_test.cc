#include "server/remote_evaluator.h"

#include <gtest/gtest.h>

#include <numeric>

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

}  // namespace
}  // namespace wormdrag::server
