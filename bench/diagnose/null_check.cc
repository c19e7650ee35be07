// --null-check: is the noise-only floor right? The TRUE model on the data, on fresh-noise
// data and on replicates.
#include <algorithm>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int NullCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // Is the null floor right? For the `none` pairs of the TUNING seed set: held-out E
  // (blocked, nothing fitted) of the true model on (a) the data, (b) the same case
  // re-synthesised with fresh noise (an ideal null), and on replicates made as the
  // diagnosis makes them (FitTaskData) but from the TRUE coefficients, their truth
  // driven by (c) the data's processed joint angles (the diagnosis's truth when the
  // gait is not periodic; --null-truth-check --truths gait measures its own),
  // (d) the processed joint angles of the CLEAN recording (the ideal truth shapes,
  // unavailable on real data). Mean over --reps replicates.
  auto cases = MakeCases(static_cast<uint64_t>(Arg(args, "--set", 11)));
  const double sigma = Arg(args, "--noise", 0.002);
  const int reps = std::max(2, static_cast<int>(Arg(args, "--reps", 3)));
  DiagnoseOptions on = o;
  on.null_replicates = reps;
  std::printf(
      "| case | source | (a) data | (b) fresh noise | (c) null (data's shapes) | (d) null (clean shapes) | "
      "(e) (c)²/null of (c) |\n|---|---|---|---|---|---|---|\n");
  auto e_of = [&](const EffectData& d, const Case& c) { return TrueModelE(d, c, o.epsilon); };
  std::array<std::vector<double>, 3> ratio;  // ((a)+(b))/2 over (c), (d), (e)
  // The gap test's p-values when the model is right: the rank of (a) and of (b) among
  // the (c) replicates, by the blocked held-out E and by the unrestarted full path's,
  // and among the (d) replicates by the full path's (the null the test would have if the
  // clean shapes were known).
  std::array<std::vector<double>, 3> pvalues;
  // --coulomb-scale K multiplies both Coulomb coefficients (K < 1: more viscous bodies).
  const double mu_scale = Arg(args, "--coulomb-scale", 1.0);
  for (Case c : cases) {
    if (c.category != "none") continue;
    c.coef.mu_n *= mu_scale;
    c.coef.mu_t *= mu_scale;
    auto ks = Synth(c, src, fps, duration, sigma), ks2 = Synth(c, src, fps, duration, sigma, 1000003),
         clean = Synth(c, src, fps, duration, 0.0);
    if (!ks.ok() || !ks2.ok() || !clean.ok()) continue;
    auto d = PrepareForDiagnosis(*ks, o), d2 = PrepareForDiagnosis(*ks2, o);
    if (!d.ok() || !d2.ok()) continue;
    // (e): each replicate of (c) gets a replicate of its own (second generation, E2);
    // if every generation lowers E by the same factor, E(data) ≈ E1² / E2.
    std::array<double, 3> e{0, 0, 0};
    double e2 = 0;
    std::array<std::vector<double>, 3> rep_e;  // (c) blocked, (c) full path, (d) full path
    bool ok = true;
    for (int r = 1; r <= reps && ok; ++r) {
      auto x = FitTaskData(*ks, on, r, c.coef, sigma), z = FitTaskData(*clean, on, r, c.coef, sigma);
      ok = x.ok() && z.ok();
      if (!ok) break;
      e[0] += e_of(*x, c) / reps;
      rep_e[0].push_back(e_of(*x, c));
      rep_e[1].push_back(TrueModelE(*x, c, o.epsilon, nullptr, false));
      rep_e[2].push_back(TrueModelE(*z, c, o.epsilon, nullptr, false));
      e[1] += e_of(*z, c) / reps;
      auto gen1 = NullPair(*d, c.coef, o.epsilon, sigma, r);
      ok = gen1.ok();
      if (!ok) break;
      auto y = FitTaskData(*gen1, on, r, c.coef, sigma);
      ok = y.ok();
      if (ok) e2 += e_of(*y, c) / reps;
    }
    if (!ok) continue;
    e[2] = e[0] * e[0] / e2;
    const double ea = e_of(*d, c), eb = e_of(*d2, c);
    for (int k = 0; k < 3; ++k) ratio[k].push_back(0.5 * (ea + eb) / e[k]);
    for (const EffectData* data : {&*d, &*d2}) {
      pvalues[0].push_back(RankPValue(e_of(*data, c), rep_e[0]));
      const double full = TrueModelE(*data, c, o.epsilon, nullptr, false);
      pvalues[1].push_back(RankPValue(full, rep_e[1]));
      pvalues[2].push_back(RankPValue(full, rep_e[2]));
    }
    std::printf("| %d | %s | %.4g | %.4g | %.4g | %.4g | %.4g |\n", static_cast<int>(c.seed % 1000), SourceName(c), ea,
                eb, e[0], e[1], e[2]);
    std::fflush(stdout);
  }
  if (ratio[0].empty()) return 1;
  std::printf("\n((a)+(b))/2 over the null's E, median [min, max]:");
  for (int k = 0; k < 3; ++k) {
    auto v = ratio[k];
    std::sort(v.begin(), v.end());
    std::printf(" (%c) %.2f [%.2f, %.2f]", 'c' + k, v[v.size() / 2], v.front(), v.back());
  }
  std::printf("\n");
  std::printf("p-values among %d replicates (a right null gives uniform ones):\n", reps);
  const char* names[] = {"blocked held-out E", "full-path E", "full-path E against (d)"};
  for (int k = 0; k < 3; ++k) PrintPValueShares(names[k], pvalues[k]);
  return 0;
}

}  // namespace wormdrag::diagnose_bench
