#include "core/common/json.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Readers of stored results tell an unbounded value ("inf") from a missing one (null).
TEST(Json, NonFiniteNumbersHaveTheEncodingsReadersExpect) {
  EXPECT_EQ(Dump(NumberOrNull(0.5)), "0.5");
  EXPECT_EQ(Dump(NumberOrNull(kInf)), "null");
  EXPECT_EQ(Dump(NumberOrNull(std::nan(""))), "null");
  EXPECT_EQ(Dump(NumberOrInf(-2.0)), "-2.0");
  EXPECT_EQ(Dump(NumberOrInf(kInf)), "\"inf\"");
  EXPECT_EQ(Dump(NumberOrInf(-kInf)), "\"-inf\"");
  EXPECT_EQ(Dump(NumberOrInf(std::nan(""))), "null");
}

TEST(Json, KeepsKeyOrderAndDumpsAnyBytes) {
  const Json j = {{"z", 1}, {"a", "x\"y\n"}};
  EXPECT_EQ(Dump(j), "{\"z\":1,\"a\":\"x\\\"y\\n\"}");
  // A file name that is not UTF-8 is replaced, not thrown on.
  EXPECT_EQ(Dump(Json("a\xff")), "\"a\xef\xbf\xbd\"");
}

}  // namespace
}  // namespace wormdrag
