// A clock the test moves by hand, for lease and deadline tests of the scheduler.
#pragma once

#include <chrono>
#include <mutex>

#include "server/clock.h"

namespace wormdrag::server {

class ManualClock final : public Clock {
 public:
  time_point Now() const override {
    std::lock_guard<std::mutex> l(mu_);
    return now_;
  }
  void Advance(std::chrono::milliseconds d) {
    std::lock_guard<std::mutex> l(mu_);
    now_ += d;
  }

 private:
  mutable std::mutex mu_;
  time_point now_{std::chrono::hours(1)};
};

}  // namespace wormdrag::server
