#include "core/common/parallel.h"

#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>
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

// Within one call each worker id belongs to one thread, and the caller is worker 0.
TEST(ParallelFor, WorkerIdsAreUniqueWithinACall) {
  for (int round = 0; round < 20; ++round) {
    const int threads = 4;
    std::mutex mu;
    std::vector<std::thread::id> owner(threads);
    bool clash = false;
    ParallelFor(200, threads, [&](int worker, int64_t) {
      std::lock_guard<std::mutex> lock(mu);
      if (owner[worker] == std::thread::id())
        owner[worker] = std::this_thread::get_id();
      else if (owner[worker] != std::this_thread::get_id())
        clash = true;
    });
    EXPECT_FALSE(clash);
    // Worker 0 may have run nothing when the others took every item.
    if (owner[0] != std::thread::id()) { EXPECT_EQ(owner[0], std::this_thread::get_id()); }
  }
}

// A call from inside f finishes even when every pool thread is taken by the outer call.
TEST(ParallelFor, NestedCallsFinishAndCoverEveryItem) {
  const int outer = 8, inner = 50;
  std::vector<std::atomic<int>> calls(outer * inner);
  std::atomic<bool> bad_worker{false};
  ParallelFor(outer, 4, [&](int, int64_t i) {
    ParallelFor(inner, 4, [&](int worker, int64_t j) {
      if (worker < 0 || worker >= 4) bad_worker = true;
      ParallelFor(3, 3, [&](int, int64_t) {});  // and one level deeper
      ++calls[i * inner + j];
    });
  });
  for (const auto& c : calls) EXPECT_EQ(c.load(), 1);
  EXPECT_FALSE(bad_worker.load());
}

// Several threads calling at once share the pool; each call keeps its own worker ids.
TEST(ParallelFor, ConcurrentCallersEachGetTheirItemsWithExclusiveWorkers) {
  const int callers = 4, calls_each = 100, n = 64, threads = 3;
  std::atomic<bool> wrong{false};
  std::vector<std::thread> ts;
  for (int c = 0; c < callers; ++c) {
    ts.emplace_back([&] {
      for (int k = 0; k < calls_each; ++k) {
        std::vector<std::atomic<int>> seen(n), busy(threads);
        ParallelFor(n, threads, [&](int worker, int64_t i) {
          if (busy[worker].fetch_add(1) != 0) wrong = true;
          ++seen[i];
          busy[worker].fetch_sub(1);
        });
        for (const auto& s : seen)
          if (s.load() != 1) wrong = true;
      }
    });
  }
  for (auto& t : ts) t.join();
  EXPECT_FALSE(wrong.load());
}

// Threads are kept between calls, so many tiny calls stay cheap and correct.
TEST(ParallelFor, ManyShortCalls) {
  int64_t total = 0;
  for (int k = 0; k < 20000; ++k) {
    std::atomic<int64_t> sum{0};
    ParallelFor(3, 1 + k % 4, [&](int, int64_t i) { sum += i + 1; });
    total += sum.load();
  }
  EXPECT_EQ(total, 20000 * 6);
}

// A result assembled by item index is the same on any number of threads.
TEST(ParallelFor, ResultsByItemDoNotDependOnTheThreadCount) {
  const int64_t n = 3000;
  auto run = [&](int threads) {
    std::vector<double> out(n);
    ParallelFor(n, threads, [&](int, int64_t i) {
      double x = 0;
      for (int k = 1; k <= 50; ++k) x += std::sin(double(i * k)) / k;
      out[i] = x;
    });
    return out;
  };
  const std::vector<double> one = run(1);
  for (int threads : {2, 5, 16}) EXPECT_EQ(run(threads), one) << threads << " threads";
}

}  // namespace
}  // namespace wormdrag
