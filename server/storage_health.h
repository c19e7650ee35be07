// Storage faults of the coordinator's SQLite file, met with patience instead of lost
// work:
//  - SQLITE_BUSY/LOCKED past busy_timeout (another process holds the write lock):
//    the write is retried with back-off for up to busy_retry_for, each retry logged
//    (event=sqlite_busy), before its error is returned.
//  - SQLITE_FULL (disk full): the storage is "full" (the gRPC health service turns
//    NOT_SERVING, event=storage_full) and a write that must not be lost (a job's
//    state, its evaluations, a batch of task results) is retried until space returns
//    (event=storage_recovered) or the coordinator stops. Writes that can be refused
//    instead (a new submission, a task result not yet queued) fail at once while
//    the storage is full, so their callers see RESOURCE_EXHAUSTED or UNAVAILABLE and
//    nothing waits unseen.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>

#include "core/common/status.h"

namespace wormdrag::server {

class StorageHealth {
 public:
  explicit StorageHealth(std::chrono::milliseconds busy_retry_for = std::chrono::minutes(5))
      : busy_retry_for_(busy_retry_for) {}

  enum class WhenFull { kWait, kFail };
  // Runs `op` (one store write, a transaction of its own) until it succeeds, with the
  // retries above. kFail: a full disk returns at once (and still marks the storage full).
  // `abandon` (checked between attempts): give up with the last error when true.
  Status Retry(const std::string& what, const std::function<Status()>& op, WhenFull when_full = WhenFull::kWait,
               const std::function<bool()>& abandon = {});

  bool full() const;
  std::string full_reason() const;
  // Ends every retry with its last error (shutdown).
  void Stop();

 private:
  void MarkFull(const std::string& what, const Status& st);
  void MarkRecovered(const std::string& what);
  // Sleeps `d` unless stopping; false when stopping.
  bool Sleep(std::chrono::milliseconds d);

  const std::chrono::milliseconds busy_retry_for_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  bool full_ = false;
  std::string full_reason_;
  std::chrono::steady_clock::time_point full_since_, full_logged_;
};

}  // namespace wormdrag::server
