#include "core/estimate/search.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "core/filter/shape_smoothing.h"
#include "core/sim/pattern.h"

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
  const auto two = RefinementSets(
      {{Coefficients{0.5, 0.5, 0.005, 0.005}, 1}, {Coefficients{0.6, 0.5, 0.005, 0.005}, 2}}, o);
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

// The paper's pattern `index` simulated with `c` for 1 s at `fps`, as estimated.
Kinematics Recording1s(int index, const Coefficients& c, const EvaluationOptions& eval, double fps) {
  RecordingSpec spec;
  spec.fps = fps;
  spec.duration = 1;
  spec.substeps = eval.SubstepsFor(spec.fps);
  spec.as_estimated = true;
  auto r = GenerateRecording(Locomotion(index), c, eval.sim, spec);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? *r : Kinematics();
}

// Phase 3 with the Jacobian from the simulator's sensitivities and from the
// finite-difference stencil, from two starts, on a clean synthetic pair and on one with
// every frame displaced at random (tracking noise of the position, shapes kept clean),
// with the scale free (the default) and held. Phase 3 minimises the mean squared
// distance f: exact Jacobians reach an f at least as low, up to what the data resolve.
// With noise, f is flat along a valley, and the math library's last bits can send the
// two runs to different points of it; the data tell two points apart only when n·Δf/f
// exceeds one (one unit of −2 log-likelihood, n the independent noise draws: one
// displacement per frame and axis), so the exact f may exceed the other by f/n there.
// Clean data have no noise to hide in, and the two f agree to 1e-6. E (which picks the winner)
// is then equal or lower up to 1e-4: the scale, set by inertia alone, and η_n under
// Coulomb friction are nearly free, so the two runs stop at points that differ there
// by up to a few %, with E equal to 1e-4 (clean, free: both on the truth's path). Free
// (the default), exact Jacobians take fewer sets.
TEST(Phase3, ExactJacobiansReachTheSameOptimumWithFewerSets) {
  const Coefficients truth{0.55, 0.25, 0.006, 0.003};
  EvaluationOptions eval;
  eval.t_max = 1;
  std::array<Kinematics, 2> k, displaced;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 5e-4);  // mm, 0.05 % BL
  for (int j = 0; j < 2; ++j) {
    k[j] = displaced[j] = Recording1s(j + 1, truth, eval, 300);
    for (auto& f : displaced[j].frames) {
      const Vec2 d(noise(rng), noise(rng));
      for (auto& p : f.p) p += d;
    }
  }
  auto clean = PairedPath::Create(k, {"clean L1", "L2"}, eval);
  ASSERT_TRUE(clean.ok()) << clean.status().ToString();
  auto noisy = PairedPath::Create(displaced, {"displaced L1", "L2"}, eval);
  ASSERT_TRUE(noisy.ok()) << noisy.status().ToString();
  const std::vector<ScoredSet> starts = {{{0.5, 0.3, 0.005, 0.0035}, 0}, {{0.6, 0.25, 0.0065, 0.0025}, 0}};
  for (const auto& pair : {*clean, *noisy})
    for (bool fix_scale : {false, true}) {
      LocalEvaluator ev(pair, 2);
      PhaseSummary fd_summary, exact_summary;
      Phase3Options fd, exact;
      fd.exact_jacobians = false;
      fd.fix_scale = exact.fix_scale = fix_scale;
      auto a = RunPhase3(starts, SearchOptions(), fd, ev, &fd_summary);
      ASSERT_TRUE(a.ok()) << a.status().ToString();
      auto b = RunPhase3(starts, SearchOptions(), exact, ev, &exact_summary);
      ASSERT_TRUE(b.ok()) << b.status().ToString();
      std::printf("%s, %s scale\n  finite differences: %s\n  exact:              %s\n", pair->worm(0).name.c_str(),
                  fix_scale ? "fixed" : "free", fd_summary.OneLineReport().c_str(),
                  exact_summary.OneLineReport().c_str());
      std::vector<double> f;
      EvaluationRequest msd;
      msd.objective = Objective::kMeanSquaredDistance;
      ASSERT_TRUE(ev.Evaluate({a->set, b->set}, &f, msd).ok());
      std::printf("  f: finite differences %.9g, exact %.9g mm^2\n", f[0], f[1]);
      const double L = pair->mean_body_length();
      const double draws = 2.0 * 2 * displaced[0].frames.size();
      EXPECT_LE(f[1], f[0] * (1 + (pair == *noisy ? 1 / draws : 1e-6)));
      EXPECT_LE(b->e, a->e * (1 + 1e-4) + 1e-9 * L);
      if (pair == *clean && !fix_scale) {
        EXPECT_LT(b->e / L, 1e-8);  // the truth's path
      }
      if (!fix_scale) { EXPECT_LT(exact_summary.sets, fd_summary.sets); }
    }
}

// Forwards to a LocalEvaluator, counting the sets its cuts stopped, or hiding the
// cuts from it (so that it simulates every set to its end).
class CutsProbe : public BatchEvaluator {
 public:
  CutsProbe(std::shared_ptr<const PairedPath> pair, bool hide) : inner_(std::move(pair), 2), hide_(hide) {}
  Status Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                  const EvaluationRequest& request) override {
    EvaluationRequest r = request;
    if (hide_) r.set_cuts.clear();
    WORMDRAG_RETURN_IF_ERROR(inner_.Evaluate(sets, e, r));
    for (double v : *e) abandoned += IsAbandoned(v);
    return Status::Ok();
  }
  Status EvaluateResiduals(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* r,
                           const EvaluationRequest& request) override {
    return inner_.EvaluateResiduals(sets, r, request);
  }
  bool HasJacobians() const override { return true; }
  Status EvaluateResidualJacobians(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* r,
                                   std::vector<std::vector<double>>* jac, const EvaluationRequest& request) override {
    return inner_.EvaluateResidualJacobians(sets, r, jac, request);
  }
  int parallelism() const override { return inner_.parallelism(); }
  int64_t abandoned = 0;

 private:
  LocalEvaluator inner_;
  bool hide_;
};

// The two worms of a 1 s pair at 100 fps (coefficients 0.55, 0.25, 0.006, 0.003),
// with Gaussian noise of `sigma_mm` on every point drawn from `seed` (none at 0).
std::array<Kinematics, 2> OneSecondPair(const EvaluationOptions& eval, double sigma_mm, uint64_t seed) {
  const Coefficients truth{0.55, 0.25, 0.006, 0.003};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_mm);
  std::array<Kinematics, 2> k;
  for (int j = 0; j < 2; ++j) {
    k[j] = Recording1s(j + 1, truth, eval, 100);
    if (sigma_mm > 0)
      for (auto& f : k[j].frames)
        for (auto& p : f.p) p += Vec2(noise(rng), noise(rng));
  }
  return k;
}

// The scale-ray search stops the factors proven worse than its ray's best: Phase 3
// ends at the same bits, after the same number of sets, as when every set runs to its
// end, on clean data and on noisy data.
TEST(Phase3, RaySearchCutsChangeNoBit) {
  EvaluationOptions eval;
  eval.t_max = 1;
  for (bool noisy : {false, true}) {
    auto pair = PairedPath::Create(OneSecondPair(eval, noisy ? 2e-3 : 0, 11), {"L1", "L2"}, eval);
    ASSERT_TRUE(pair.ok()) << pair.status().ToString();
    const std::vector<ScoredSet> starts = {{{0.5, 0.3, 0.005, 0.0035}, 0}, {{0.3, 0.15, 0.002, 0.001}, 0}};
    CutsProbe with(*pair, false), without(*pair, true);
    PhaseSummary a_summary, b_summary;
    auto a = RunPhase3(starts, SearchOptions(), Phase3Options(), with, &a_summary);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    auto b = RunPhase3(starts, SearchOptions(), Phase3Options(), without, &b_summary);
    ASSERT_TRUE(b.ok()) << b.status().ToString();
    EXPECT_EQ(a->set, b->set) << a->set.ToString() << " vs " << b->set.ToString();
    EXPECT_EQ(a->e, b->e);
    EXPECT_EQ(a_summary.sets, b_summary.sets);
    EXPECT_EQ(a_summary.termination, b_summary.termination);
    EXPECT_GT(with.abandoned, 0) << (noisy ? "noisy" : "clean");
    EXPECT_EQ(without.abandoned, 0);
  }
}

// The scale rounds end once a round gains less than one unit of χ² (f / m per unit):
// on noisy data they stop sooner than rounds that go on while f falls by 1e-6 of
// itself, and what they leave is below the data's resolution, with the determined
// ratio where the longer search puts it.
TEST(Phase3, ScaleRoundsEndWhereTheDataStopResolvingF) {
  EvaluationOptions eval;
  eval.t_max = 1;
  std::array<Kinematics, 2> k = OneSecondPair(eval, 2e-3, 5);
  for (int j = 0; j < 2; ++j) {
    SmoothingReport report;
    auto smoothed = SmoothShapesAuto(k[j], SmoothingSplineOptions(), &report);  // as a job smooths
    ASSERT_TRUE(smoothed.ok()) << smoothed.status().ToString();
    k[j] = *smoothed;
  }
  auto pair = PairedPath::Create(k, {"L1", "L2"}, eval);
  ASSERT_TRUE(pair.ok()) << pair.status().ToString();
  const std::vector<ScoredSet> starts = {{{0.5, 0.3, 0.005, 0.0035}, 0}};
  LocalEvaluator ev(*pair, 2);
  Phase3Options resolved, exhaustive;
  exhaustive.round_chi2 = 0;
  PhaseSummary rs, es;
  auto a = RunPhase3(starts, SearchOptions(), resolved, ev, &rs);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  auto b = RunPhase3(starts, SearchOptions(), exhaustive, ev, &es);
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  std::printf("resolved:   %s\nexhaustive: %s\n", rs.OneLineReport().c_str(), es.OneLineReport().c_str());
  EXPECT_LT(rs.sets, es.sets);
  std::vector<std::vector<double>> r;
  ASSERT_TRUE(ev.EvaluateResiduals({a->set, b->set}, &r).ok());
  double f[2] = {0, 0};
  for (int i = 0; i < 2; ++i)
    for (double v : r[i]) f[i] += v * v;
  const double m = static_cast<double>(r[0].size());
  std::printf("f %.9g vs %.9g mm^2, %.3g units of chi^2 apart (m = %.0f)\n", f[0], f[1], m * (f[0] - f[1]) / f[1], m);
  EXPECT_LT(m * (f[0] - f[1]) / f[1], 3);
  const double k_mu[2] = {a->set.mu_n / a->set.mu_t, b->set.mu_n / b->set.mu_t};
  EXPECT_NEAR(k_mu[0] / k_mu[1], 1, 0.01) << a->set.ToString() << " vs " << b->set.ToString();

  Phase3Options bad;
  bad.round_chi2 = -1;
  EXPECT_EQ(bad.Validate().code(), Status::Code::kInvalidArgument);
}

}  // namespace
}  // namespace wormdrag
