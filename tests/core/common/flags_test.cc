#include "core/common/flags.h"

#include <limits>

#include <gtest/gtest.h>

namespace wormdrag::flags {
namespace {

const std::vector<Option> kOptions = {
    {"out", "FILE", "where to write", "out.csv"},
    {"fps", "F", "frame rate", ""},
    {"fast", "", "a flag", ""},
    {"note", "T", "first line\nsecond line", ""},
};

TEST(Flags, ParsesValuesFlagsAndPositionals) {
  auto a = Args::Parse({"a.csv", "--out", "x.csv", "--fps=30", "--fast", "b.csv"}, kOptions);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_EQ(a->Get("out"), "x.csv");
  EXPECT_EQ(*a->GetDouble("fps", 0), 30);
  EXPECT_TRUE(a->Has("fast"));
  EXPECT_FALSE(a->Has("note"));
  EXPECT_EQ(a->Get("note", "none"), "none");
  EXPECT_EQ(a->positionals(), (std::vector<std::string>{"a.csv", "b.csv"}));
}

TEST(Flags, TheLastOfARepeatedOptionWinsAndAllAreKept) {
  auto a = Args::Parse({"--out", "1", "--out=2"}, kOptions);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->Get("out"), "2");
  EXPECT_EQ(a->GetAll("out"), (std::vector<std::string>{"1", "2"}));
}

TEST(Flags, RejectsBadCommandLines) {
  EXPECT_EQ(Args::Parse({"--nope"}, kOptions).status().message(), "unknown option --nope (see --help)");
  EXPECT_EQ(Args::Parse({"--out"}, kOptions).status().message(), "option --out needs a value FILE");
  EXPECT_EQ(Args::Parse({"--fast=1"}, kOptions).status().message(), "option --fast takes no value");
  EXPECT_EQ(Args::Parse({"x"}, kOptions, false).status().message(), "unexpected argument 'x' (see --help)");
  auto a = Args::Parse({"--fps", "3x"}, kOptions);
  ASSERT_TRUE(a.ok());
  EXPECT_FALSE(a->GetDouble("fps", 0).ok());
  EXPECT_FALSE(a->GetInt("fps", 0).ok());
  EXPECT_FALSE(a->Require("out").ok());
}

TEST(Flags, WholeNumbersInARangeSayTheRange) {
  auto a = Args::Parse({"--fps", "12", "--out", "2.5"}, kOptions);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(*a->GetIntIn("fps", 0, 1, 64), 12);
  EXPECT_EQ(*a->GetIntIn("note", 7, 1, 5), 7);  // absent: the fallback, unchecked
  EXPECT_EQ(a->GetIntIn("fps", 0, 1, 10).status().message(), "--fps must be a whole number from 1 to 10, not '12'");
  EXPECT_EQ(a->GetIntIn("out", 0, 0, std::numeric_limits<long>::max()).status().message(),
            "--out must be a whole number >= 0, not '2.5'");
  // A value past the range of long is refused, not clamped to its end.
  auto big = Args::Parse({"--fps", "99999999999999999999"}, kOptions);
  ASSERT_TRUE(big.ok());
  EXPECT_FALSE(big->GetIntIn("fps", 0, 0, std::numeric_limits<long>::max()).ok());
  EXPECT_FALSE(big->GetInt("fps", 0).ok());
  long v = 0;
  EXPECT_FALSE(ToLong("-99999999999999999999", &v));
  EXPECT_TRUE(ToLong("-42", &v));
  EXPECT_EQ(v, -42);
}

TEST(Flags, RealNumbersOutOfRangeOrNotFiniteAreRefused) {
  double d = 0;
  EXPECT_TRUE(ToDouble("2.5e-3", &d));
  EXPECT_EQ(d, 2.5e-3);
  for (const char* bad : {"1e999", "-1e999", "1e-999", "inf", "nan", "1.5x", ""})
    EXPECT_FALSE(ToDouble(bad, &d)) << bad;
  auto a = Args::Parse({"--fps", "1e999"}, kOptions);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->GetDouble("fps", 0).status().message(), "--fps: not a number: '1e999'");
}

TEST(Flags, ListsOfRealNumbersStopAtTheFirstBadItem) {
  std::vector<double> v;
  std::string bad;
  auto positive = [](double x) { return x > 0; };
  EXPECT_TRUE(ToDoubles("0.5,1,2e1", positive, &v, &bad));
  EXPECT_EQ(v, (std::vector<double>{0.5, 1, 20}));
  EXPECT_FALSE(ToDoubles("1,-2,x", positive, &v, &bad));
  EXPECT_EQ(bad, "-2");
  EXPECT_FALSE(ToDoubles("1,,2", positive, &v, &bad));
  EXPECT_EQ(bad, "");
  EXPECT_FALSE(ToDoubles("1,inf", positive, &v, &bad));
  EXPECT_EQ(bad, "inf");
}

TEST(Flags, UsageListsEveryOptionWithItsDefault) {
  const std::string u = Usage("prog", "[options]", "Does things.", kOptions);
  EXPECT_EQ(u.rfind("usage: prog [options]\n\nDoes things.\n\noptions:\n", 0), 0u) << u;
  EXPECT_NE(u.find("  --out FILE                where to write (default out.csv)\n"), std::string::npos) << u;
  EXPECT_NE(u.find("  --note T                  first line\n                            second line\n"),
            std::string::npos)
      << u;
}

TEST(Flags, ParseHandlesHelpAndErrorsWithExitCodes) {
  const Spec spec{"prog", "[options]", "Does things.", kOptions, false};
  Args a;
  testing::internal::CaptureStdout();
  EXPECT_EQ(Parse({"--out", "x", "-h"}, spec, &a), 0);
  EXPECT_NE(testing::internal::GetCapturedStdout().find("usage: prog"), std::string::npos);
  testing::internal::CaptureStderr();
  EXPECT_EQ(Parse({"--bogus"}, spec, &a), 2);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "prog: unknown option --bogus (see --help)\n");
  EXPECT_EQ(Parse({"--fast"}, spec, &a), std::nullopt);
  EXPECT_TRUE(a.Has("fast"));
}

TEST(Flags, FirstOptionAndArgList) {
  EXPECT_EQ(FirstOption({"1", "--db=x", "--server", "h"}, {"server", "db"}), "db");
  EXPECT_EQ(FirstOption({"--dbx"}, {"db"}), "");
  char p[] = "p", x[] = "x";
  char* argv[] = {p, x};
  EXPECT_EQ(ArgList(2, argv), std::vector<std::string>{"x"});
  EXPECT_TRUE(ArgList(1, argv).empty());
}

}  // namespace
}  // namespace wormdrag::flags
