#include "server/storage_health.h"

#include <algorithm>

#include <spdlog/spdlog.h>

namespace wormdrag::server {

Status StorageHealth::Retry(const std::string& what, const std::function<Status()>& op, WhenFull when_full,
                            const std::function<bool()>& abandon) {
  const auto start = std::chrono::steady_clock::now();
  std::chrono::milliseconds backoff(50);
  for (int attempt = 1;; ++attempt) {
    Status st = op();
    if (st.ok()) {
      MarkRecovered(what);
      return st;
    }
    if (st.code() == Status::Code::kResourceExhausted) {
      MarkFull(what, st);
      if (when_full == WhenFull::kFail) return st;
    } else if (st.code() == Status::Code::kUnavailable) {
      if (std::chrono::steady_clock::now() - start + backoff > busy_retry_for_) return st;
      spdlog::warn("event=sqlite_busy what=\"{}\" attempt={} retry_ms={} error=\"{}\"", what, attempt, backoff.count(),
                   st.message());
    } else {
      return st;
    }
    if ((abandon && abandon()) || !Sleep(backoff) || (abandon && abandon())) return st;
    backoff = std::min(backoff * 2, std::chrono::milliseconds(2000));
  }
}

bool StorageHealth::full() const {
  std::lock_guard<std::mutex> l(mu_);
  return full_;
}

std::string StorageHealth::full_reason() const {
  std::lock_guard<std::mutex> l(mu_);
  return full_reason_;
}

void StorageHealth::Stop() {
  std::lock_guard<std::mutex> l(mu_);
  stopping_ = true;
  cv_.notify_all();
}

void StorageHealth::MarkFull(const std::string& what, const Status& st) {
  std::lock_guard<std::mutex> l(mu_);
  const auto now = std::chrono::steady_clock::now();
  if (!full_) {
    full_ = true;
    full_since_ = now;
    full_reason_ = st.message();
    full_logged_ = now;
    spdlog::error(
        "event=storage_full what=\"{}\" error=\"{}\": the disk of the job store is full; not serving, "
        "writes wait until space returns",
        what, st.message());
  } else if (now - full_logged_ > std::chrono::seconds(30)) {
    full_logged_ = now;
    spdlog::error("event=storage_full what=\"{}\" seconds={:.0f} error=\"{}\"", what,
                  std::chrono::duration<double>(now - full_since_).count(), st.message());
  }
}

void StorageHealth::MarkRecovered(const std::string& what) {
  std::lock_guard<std::mutex> l(mu_);
  if (!full_) return;
  full_ = false;
  full_reason_.clear();
  spdlog::info("event=storage_recovered what=\"{}\" seconds_full={:.1f}", what,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - full_since_).count());
}

bool StorageHealth::Sleep(std::chrono::milliseconds d) {
  std::unique_lock<std::mutex> l(mu_);
  cv_.wait_for(l, d, [&] { return stopping_; });
  return !stopping_;
}

}  // namespace wormdrag::server
