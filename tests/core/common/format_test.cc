#include "core/common/format.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

std::string PrintfG(int digits, double v) {
  char b[400];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}
std::string PrintfF(int digits, double v) {
  char b[400];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

// The call sites replaced printf conversions: the text must stay what printf writes.
TEST(FormatNumber, WritesWhatPrintfWrites) {
  const double inf = std::numeric_limits<double>::infinity();
  for (double v : {0.0, -0.0, 1.0, 0.125, -2.5e-5, 1e-5, 123456789.0, 1.0 / 3, 6.02214076e23, 1e300, inf, -inf})
    for (int digits : {1, 3, 5, 6, 10, 17}) {
      EXPECT_EQ(FormatNumber(v, digits), PrintfG(digits, v)) << v << " to " << digits;
      EXPECT_EQ(FormatFixed(v, digits), PrintfF(digits, v)) << v << " to " << digits;
    }
  EXPECT_EQ(FormatNumber(0.1, 10), "0.1");
  EXPECT_EQ(FormatNumber(1e-5, 3), "1e-05");
  EXPECT_EQ(FormatFixed(12.345, 1), "12.3");
  EXPECT_EQ(FormatNumber(std::nan(""), 6), "nan");
}

// Every cell as written, the empty ones too, so that a parser refuses "1,,2" and "1,2,"
// rather than reading fewer values than were meant.
TEST(SplitList, KeepsEveryCellAsWritten) {
  using V = std::vector<std::string>;
  EXPECT_EQ(SplitList(""), V{});
  EXPECT_EQ(SplitList("a"), V{"a"});
  EXPECT_EQ(SplitList("a,b"), (V{"a", "b"}));
  EXPECT_EQ(SplitList("a,,b,"), (V{"a", "", "b", ""}));
  EXPECT_EQ(SplitList(","), (V{"", ""}));
  EXPECT_EQ(SplitList(" a ;b", ';'), (V{" a ", "b"}));
}

}  // namespace
}  // namespace wormdrag
