// --strength-check: how far each effect of a seed set moves the recorded bodies, the
// "strength" against which detection is read: the noise-free pair simulated with the
// case's effect against the same pair without it (same coefficients, drives and gaps).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int StrengthCheck(const Bench& b) {
  const int set = static_cast<int>(Arg(b.args, "--set", 11));
  std::printf(
      "Seed set %d (%s family): the noise-free path of each effect's pair against the same pair without it\n"
      "| case | effect | strength | drive | regime | fps | s | RMS point distance (um) | largest (um) |\n"
      "|---|---|---|---|---|---|---|---|---|\n",
      set, FamilyName(FamilyOfSet(set)));
  for (const Case& c : MakeCases(static_cast<uint64_t>(set))) {
    if (c.category == "none") continue;
    Case plain = c;
    plain.truth = EffectParams{};
    auto with = Synth(c, b.src, b.fps, b.duration, 0.0), without = Synth(plain, b.src, b.fps, b.duration, 0.0);
    if (!with.ok() || !without.ok()) {
      std::fprintf(stderr, "case %d: %s\n", static_cast<int>(c.seed),
                   (with.ok() ? without.status() : with.status()).ToString().c_str());
      return 1;
    }
    double sum = 0, largest = 0;
    long n = 0;
    for (int w = 0; w < 2; ++w) {
      const auto& fa = (*with)[w].frames;
      const auto& fb = (*without)[w].frames;
      for (size_t f = 0; f < std::min(fa.size(), fb.size()); ++f) {
        if (!fa[f].valid || !fb[f].valid) continue;
        for (int k = 0; k < kNumPoints; ++k) {
          const double e = (fa[f].p[k] - fb[f].p[k]).norm();
          sum += e * e;
          largest = std::max(largest, e);
          ++n;
        }
      }
    }
    std::printf("| %d | %s | %d | %s | %s | %g | %g | %.2f | %.2f |\n", static_cast<int>(c.seed), c.effect.c_str(),
                c.strength, SourceName(c), c.regime.c_str(), FpsOf(c, b.fps), DurationOf(c, b.duration),
                1e3 * std::sqrt(sum / std::max(1L, n)), 1e3 * largest);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
