// The time source of the scheduler's leases, deadlines and worker liveness. The real
// clock is the default; unit tests inject a clock they move by hand, so lease expiry
// and execution deadlines are tested without sleeping.
#pragma once

#include <chrono>

namespace wormdrag::server {

class Clock {
 public:
  using time_point = std::chrono::steady_clock::time_point;
  virtual ~Clock() = default;
  virtual time_point Now() const = 0;
  // std::chrono::steady_clock; one instance for the process.
  static const Clock& Real();
};

}  // namespace wormdrag::server
