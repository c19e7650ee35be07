// The one parallel loop of wormdrag.
#pragma once

#include <cstdint>
#include <functional>

namespace wormdrag {

// Calls f(worker, i) for every i in [0, n) on up to `threads` threads, the calling thread
// among them, and returns when all calls have returned. `worker` (0 … threads − 1) names
// the thread, so that each keeps its own workspace. Items are handed out one at a time
// in increasing order, so items of uneven cost balance. The threads live for one call:
// every caller's items take milliseconds or more, against microseconds to start a
// thread. f must not throw.
void ParallelFor(int64_t n, int threads, const std::function<void(int worker, int64_t i)>& f);

}  // namespace wormdrag
