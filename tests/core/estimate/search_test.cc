#include "core/estimate/search.h"

#include <algorithm>
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

TEST(Search, KeepCountIsWhatSelectBestKeeps) {
  std::vector<Coefficients> sets(1234);
  std::vector<double> e(1234);
  for (size_t i = 0; i < e.size(); ++i) e[i] = static_cast<double>(i);
  for (double p : {0.01, 0.2, 1.0, 2.5, 100.0})
    EXPECT_EQ(static_cast<int64_t>(SelectBest(sets, e, p).size()), KeepCount(sets.size(), p)) << p;
}

TEST(Search, Phase1PassesListEveryGridSetOnce) {
  for (int n_max : {1, 4, 5}) {
    SearchOptions o;
    o.n_max = n_max;
    const auto grid = GridSets(o);
    std::vector<double> e(grid.size(), INFINITY);
    const auto coarse = CoarseGridPass(o);
    for (size_t i : coarse) {
      const auto a = grid[i].AsArray();
      for (int c = 0; c < 4; ++c) EXPECT_EQ(std::lround(a[c] / (c < 2 ? o.d_mu : o.d_eta)) % 2, 0);
      e[i] = grid[i].mu_n + grid[i].eta_t;  // any values
    }
    const auto fine = FineGridPass(o, e, 3);
    std::vector<int> seen(grid.size(), 0);
    for (size_t i : coarse) ++seen[i];
    for (size_t i : fine) ++seen[i];
    for (size_t i = 0; i < grid.size(); ++i) ASSERT_EQ(seen[i], 1) << "n_max " << n_max << " set " << i;
  }
}

TEST(Search, FineGridPassPutsPromisingSetsFirstWhateverWasAbandoned) {
  SearchOptions o;
  o.n_max = 4;
  const auto grid = GridSets(o);
  // E grows with the distance from grid point (1, 3, 1, 3), off the coarse subgrid.
  auto f = [&](size_t i) {
    const auto a = grid[i].AsArray();
    return std::hypot(a[0] / o.d_mu - 1, a[1] / o.d_mu - 3, a[2] / o.d_eta - 1) + std::abs(a[3] / o.d_eta - 3);
  };
  std::vector<double> e(grid.size(), INFINITY);
  for (size_t i : CoarseGridPass(o)) e[i] = f(i);
  const auto order = FineGridPass(o, e, 30);  // the 16 coarse points nearest the optimum tie
  // A neighbour of the optimum comes first, and the first tenth is better on average
  // than the rest.
  const auto first = grid[order.front()].AsArray();
  const double opt[4] = {1, 3, 1, 3};
  for (int c = 0; c < 4; ++c) EXPECT_LE(std::abs(first[c] / (c < 2 ? o.d_mu : o.d_eta) - opt[c]), 1.001) << c;
  double head = 0, tail = 0;
  const size_t tenth = order.size() / 10;
  for (size_t k = 0; k < order.size(); ++k) (k < tenth ? head : tail) += f(order[k]);
  EXPECT_LT(head / tenth, 0.5 * tail / (order.size() - tenth));
  // Coarse sets above the cap (the 30th smallest coarse E) abandoned instead: same order.
  std::vector<double> sorted;
  for (double v : e)
    if (std::isfinite(v)) sorted.push_back(v);
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> some_abandoned = e;
  int k = 0;
  for (size_t i : CoarseGridPass(o))
    if (e[i] > sorted[29] && ++k % 2 == 0) some_abandoned[i] = kAbandoned;
  EXPECT_GT(k, 10);
  EXPECT_EQ(FineGridPass(o, some_abandoned, 30), order);
}

TEST(Search, RefinementPassPutsTheSurvivorsFirst) {
  SearchOptions o;
  const auto grid = GridSets(o);
  const std::vector<ScoredSet> kept = {{grid[7000], 1}, {grid[7001], 2}, {grid[20], 3}};
  const auto refined = RefinementSets(kept, o);
  const auto order = RefinementPass(refined, kept);
  ASSERT_EQ(order.size(), refined.size());
  for (size_t k = 0; k < kept.size(); ++k) EXPECT_EQ(refined[order[k]], kept[k].set);
  std::vector<int> seen(refined.size(), 0);
  for (size_t i : order) ++seen[i];
  for (int s : seen) EXPECT_EQ(s, 1);
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
