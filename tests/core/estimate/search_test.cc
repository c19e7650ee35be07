#include "core/estimate/search.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(Search, GridHasEveryCombination) {
  SearchOptions o;
  const auto g = GridSets(o);
  EXPECT_EQ(g.size(), 14641u);
  std::set<std::array<double, 4>> unique;
  for (const auto& c : g) unique.insert(c.AsArray());
  EXPECT_EQ(unique.size(), g.size());
  EXPECT_DOUBLE_EQ(g.back().mu_n, 1.0);
  EXPECT_DOUBLE_EQ(g.back().eta_t, 0.01);
}

TEST(Search, RefinementDropsNegativesAndDuplicates) {
  SearchOptions o;
  // An interior set gives 81; a set at zero in two coordinates gives 3·3·2·2 = 36.
  EXPECT_EQ(RefinementSets({{Coefficients{0.5, 0.5, 0.005, 0.005}, 1}}, o).size(), 81u);
  EXPECT_EQ(RefinementSets({{Coefficients{0.5, 0.5, 0, 0}, 1}}, o).size(), 36u);
  // Neighbouring grid sets share half-step points: listed once.
  const auto two = RefinementSets({{Coefficients{0.5, 0.5, 0.005, 0.005}, 1}, {Coefficients{0.6, 0.5, 0.005, 0.005}, 2}}, o);
  EXPECT_EQ(two.size(), 81u + 54u);
  // The centre is bit-identical to the Phase 1 grid value (so stored E is reused).
  const auto grid = GridSets(o);
  const auto ref = RefinementSets({{grid[7000], 1}}, o);
  bool found = false;
  for (const auto& c : ref) found |= c == grid[7000];
  EXPECT_TRUE(found);
  for (const auto& c : ref) EXPECT_GE(c.mu_n, 0);
}

TEST(Search, SelectBestKeepsPercentAndSkipsInfinite) {
  std::vector<Coefficients> sets(1000);
  std::vector<double> e(1000);
  for (int i = 0; i < 1000; ++i) {
    sets[i] = {double(i), 0, 0, 0};
    e[i] = i % 7 == 0 ? INFINITY : 1000.0 - i;
  }
  const auto best = SelectBest(sets, e, 1.0);
  ASSERT_EQ(best.size(), 10u);
  EXPECT_EQ(best[0].e, 1.0);  // i = 999
  for (size_t i = 1; i < best.size(); ++i) EXPECT_LE(best[i - 1].e, best[i].e);
  EXPECT_EQ(SelectBest(sets, e, 0.01).size(), 1u);
}

TEST(Search, OptionValidation) {
  SearchOptions o;
  o.n_max = 60;  // 61^4 = 13.8 M sets
  EXPECT_EQ(o.Validate().code(), Status::Code::kResourceExhausted);
  o = {};
  o.d_mu = -0.1;
  EXPECT_EQ(o.Validate().code(), Status::Code::kInvalidArgument);
  o = {};
  o.d1 = 0;
  EXPECT_FALSE(o.Validate().ok());
  EXPECT_FALSE(ParsePhase3Method("newton").ok());
  EXPECT_EQ(*ParsePhase3Method("bobyqa"), Phase3Method::kBobyqa);
}

}  // namespace
}  // namespace wormdrag
