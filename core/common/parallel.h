// The one parallel loop of wormdrag.
#pragma once

#include <cstdint>
#include <functional>

namespace wormdrag {

// Calls f(worker, i) for every i in [0, n) on up to `threads` threads, the calling thread
// among them, and returns when all calls have returned. `worker` (0 … threads − 1) names
// the thread, so that each keeps its own workspace: within one call no two threads share
// a `worker`, and the caller is worker 0. Items are handed out one at a time in
// increasing order, so items of uneven cost balance; which worker runs which item
// depends on timing, so results must not depend on `worker`.
//
// The other threads come from one pool that lives as long as the process: it starts
// threads the first time a call asks for more than it has and keeps them, so a call
// costs a wake-up rather than thread starts. The pool is shared by every caller, and the
// caller works on its own items until none are left, so calls from several threads at
// once, and calls from inside f, finish even when every pool thread is busy (they then
// run on fewer threads). f must not throw.
void ParallelFor(int64_t n, int threads, const std::function<void(int worker, int64_t i)>& f);

}  // namespace wormdrag
