#include "core/common/parallel.h"

#include <atomic>
#include <vector>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(ParallelFor, CallsEveryItemOnceWithAWorkerInRange) {
  for (int threads : {1, 2, 3, 8}) {
    const int64_t n = 1000;
    std::vector<std::atomic<int>> calls(n);
    std::vector<std::atomic<int>> by_worker(threads);
    ParallelFor(n, threads, [&](int worker, int64_t i) {
      ASSERT_GE(worker, 0);
      ASSERT_LT(worker, threads);
      ++calls[i];
      ++by_worker[worker];
    });
    int total = 0;
    for (const auto& c : calls) EXPECT_EQ(c.load(), 1);
    for (const auto& w : by_worker) total += w.load();
    EXPECT_EQ(total, n) << threads << " threads";
  }
}

TEST(ParallelFor, UsesNoMoreWorkersThanItemsAndNoneForNoItems) {
  std::atomic<int> highest{-1}, calls{0};
  ParallelFor(2, 8, [&](int worker, int64_t) {
    ++calls;
    for (int h = highest.load(); worker > h && !highest.compare_exchange_weak(h, worker);) {}
  });
  EXPECT_EQ(calls.load(), 2);
  EXPECT_LE(highest.load(), 1);
  ParallelFor(0, 4, [&](int, int64_t) { ++calls; });
  EXPECT_EQ(calls.load(), 2);
}

// A worker's items run one after another on that worker's thread, so a per-worker
// workspace needs no lock.
TEST(ParallelFor, AWorkersItemsDoNotOverlap) {
  const int threads = 4;
  std::vector<std::atomic<int>> busy(threads);
  std::atomic<bool> overlap{false};
  ParallelFor(400, threads, [&](int worker, int64_t) {
    if (busy[worker].fetch_add(1) != 0) overlap = true;
    volatile double x = 0;
    for (int k = 0; k < 2000; ++k) x = x + k;
    busy[worker].fetch_sub(1);
  });
  EXPECT_FALSE(overlap.load());
}

}  // namespace
}  // namespace wormdrag
