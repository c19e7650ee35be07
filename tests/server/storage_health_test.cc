// StorageHealth's retries with scripted failures: a busy lock retried within its
// window, a full disk waited out (and reported as full meanwhile) or refused at once.
#include "server/storage_health.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

namespace wormdrag::server {
namespace {

using namespace std::chrono_literals;

TEST(StorageHealth, BusyIsRetriedWithinItsWindowThenReturned) {
  StorageHealth h(1s);
  int calls = 0;
  EXPECT_TRUE(h.Retry("w", [&] { return ++calls < 3 ? Status::Unavailable("locked") : Status::Ok(); }).ok());
  EXPECT_EQ(calls, 3);
  StorageHealth short_window(100ms);
  calls = 0;
  const Status st = short_window.Retry("w", [&] {
    ++calls;
    return Status::Unavailable("locked");
  });
  EXPECT_EQ(st.code(), Status::Code::kUnavailable);
  EXPECT_GE(calls, 2);
  EXPECT_FALSE(short_window.full());
}

TEST(StorageHealth, AFullDiskIsWaitedOutAndReportedMeanwhile) {
  StorageHealth h;
  std::atomic<bool> space{false};
  std::atomic<bool> seen_full{false};
  std::thread writer([&] {
    EXPECT_TRUE(h.Retry("w", [&] { return space ? Status::Ok() : Status::ResourceExhausted("disk full"); }).ok());
  });
  for (int i = 0; i < 200 && !seen_full; ++i) {
    seen_full = h.full();
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_TRUE(seen_full);
  EXPECT_EQ(h.full_reason(), "disk full");
  // A write that may be refused is, at once.
  EXPECT_EQ(h.Retry(
                 "submit", [] { return Status::ResourceExhausted("disk full"); }, StorageHealth::WhenFull::kFail)
                .code(),
            Status::Code::kResourceExhausted);
  space = true;
  writer.join();
  EXPECT_FALSE(h.full());
}

TEST(StorageHealth, StopAndAbandonEndTheWait) {
  StorageHealth h;
  std::atomic<bool> abandon{false};
  std::thread a([&] {
    EXPECT_EQ(h.Retry(
                   "w", [] { return Status::ResourceExhausted("full"); }, StorageHealth::WhenFull::kWait,
                   [&] { return abandon.load(); })
                  .code(),
              Status::Code::kResourceExhausted);
  });
  abandon = true;
  a.join();
  std::thread b([&] { EXPECT_FALSE(h.Retry("w", [] { return Status::ResourceExhausted("full"); }).ok()); });
  std::this_thread::sleep_for(50ms);
  h.Stop();
  b.join();
}

// Other errors are not retried.
TEST(StorageHealth, OtherErrorsReturnAtOnce) {
  StorageHealth h;
  int calls = 0;
  EXPECT_EQ(h.Retry("w",
                    [&] {
                      ++calls;
                      return Status::InvalidArgument("constraint");
                    })
                .code(),
            Status::Code::kInvalidArgument);
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace wormdrag::server
