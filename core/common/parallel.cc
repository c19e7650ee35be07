#include "core/common/parallel.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace wormdrag {
namespace {

// The pool never holds more threads than this, whatever a caller asks for.
constexpr int kMaxHelpers = 1023;

// One ParallelFor call: its items, and the threads taking part in it. It lives on the
// caller's stack; the caller leaves only once no helper is inside it.
struct Loop {
  const std::function<void(int, int64_t)>* f = nullptr;
  int64_t n = 0;
  int threads = 1;
  std::atomic<int64_t> next{0};
  // Guarded by Pool::mu_.
  int joined = 1;  // workers named so far: the caller is worker 0
  int active = 0;  // helpers inside Work
  std::condition_variable helpers_left;

  void Work(int worker) {
    for (int64_t i; (i = next.fetch_add(1)) < n;) (*f)(worker, i);
  }
  bool Full() const { return joined >= threads || next.load() >= n; }
};

// Helper threads waiting for loops that still take helpers.
class Pool {
 public:
  Pool() : owner_(getpid()) {}
  ~Pool();
  void Run(Loop* loop);

 private:
  void Grow(int helpers);  // with mu_ held
  void Close(Loop* loop);  // with mu_ held
  void HelperMain();

  const pid_t owner_;  // a forked child has none of the helpers
  std::mutex mu_;
  std::condition_variable work_;
  std::deque<Loop*> open_;  // loops that take more helpers, oldest first
  std::vector<std::unique_ptr<std::thread>> helpers_;
  bool stopping_ = false;
};

// Set once the pool is destroyed at exit; calls after that run on the caller alone.
// Trivially destructible, so it stays readable during static destruction.
std::atomic<bool> pool_gone{false};

Pool::~Pool() {
  pool_gone = true;
  if (getpid() != owner_) {
    // After fork() the helpers do not exist in this process and mu_ may be held by
    // one of them: leave everything as it is.
    for (auto& h : helpers_) static_cast<void>(h.release());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
  }
  work_.notify_all();
  for (auto& h : helpers_) h->join();
}

void Pool::Grow(int helpers) {
  helpers = std::min(helpers, kMaxHelpers);
  while (static_cast<int>(helpers_.size()) < helpers) {
    try {
      helpers_.push_back(std::make_unique<std::thread>([this] { HelperMain(); }));
    } catch (const std::system_error&) {
      return;  // out of threads: the loops run on the ones there are
    }
  }
}

void Pool::Close(Loop* loop) {
  const auto it = std::find(open_.begin(), open_.end(), loop);
  if (it != open_.end()) open_.erase(it);
}

void Pool::Run(Loop* loop) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    Grow(loop->threads - 1);
    open_.push_back(loop);
  }
  for (int k = 1; k < loop->threads; ++k) work_.notify_one();
  loop->Work(0);
  std::unique_lock<std::mutex> lock(mu_);
  Close(loop);
  loop->helpers_left.wait(lock, [loop] { return loop->active == 0; });
}

void Pool::HelperMain() {
  std::unique_lock<std::mutex> lock(mu_);
  for (;;) {
    work_.wait(lock, [this] { return stopping_ || !open_.empty(); });
    if (stopping_) return;
    Loop* loop = open_.front();
    const int worker = loop->joined++;
    ++loop->active;
    if (loop->Full()) open_.pop_front();
    lock.unlock();
    loop->Work(worker);
    lock.lock();
    // The caller may return as soon as it sees active == 0: loop is not touched after.
    if (--loop->active == 0) loop->helpers_left.notify_one();
  }
}

Pool& ThePool() {
  static Pool pool;
  return pool;
}

}  // namespace

void ParallelFor(int64_t n, int threads, const std::function<void(int worker, int64_t i)>& f) {
  if (n <= 0) return;
  Loop loop;
  loop.f = &f;
  loop.n = n;
  loop.threads = static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(threads, n)));
  if (loop.threads == 1 || pool_gone.load()) {
    loop.Work(0);
    return;
  }
  ThePool().Run(&loop);
}

}  // namespace wormdrag
