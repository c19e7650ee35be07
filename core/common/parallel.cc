#include "core/common/parallel.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace wormdrag {

void ParallelFor(int64_t n, int threads, const std::function<void(int worker, int64_t i)>& f) {
  const int t = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, n)));
  std::atomic<int64_t> next{0};
  auto work = [&](int worker) {
    for (int64_t i; (i = next.fetch_add(1)) < n;) f(worker, i);
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < t; ++k) pool.emplace_back(work, k);
  work(0);
  for (auto& th : pool) th.join();
}

}  // namespace wormdrag
