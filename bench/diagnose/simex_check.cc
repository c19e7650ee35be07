// --simex: gap_offset on a recorded pair or a case as tracking noise is added
// (simulation-extrapolation).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int SimexCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  // Simulation–extrapolation on a recorded pair: how does gap_offset (fitted with all
  // blocks from the given coefficients, e.g. the diagnosis's blocked refit) move when
  // tracking noise of variance λσ² is added to the recordings? If it grows with λ, the
  // noise in the drive biases it (docs/decisions/0021-simex-check.md), and the trend back
  // to λ = −1 estimates the value without noise.
  LoadedPair p;
  if (const int rc = LoadPair(b, "--simex", &p)) return rc;
  const std::array<Kinematics, 2>& ks = p.k;
  const Coefficients& c = p.coef;
  const double sigma = Arg(args, "--noise", 0.002);
  const int draws = std::max(1, static_cast<int>(Arg(args, "--reps", 3)));
  std::printf("| λ | added noise (mm) | gap_offset a per draw | mean |\n|---|---|---|---|\n");
  for (double lambda : {0.0, 0.5, 1.0, 2.0}) {
    std::printf("| %g | %.3g |", lambda, sigma * std::sqrt(lambda));
    double sum = 0;
    int n = 0;
    for (int d = 0; d < (lambda > 0 ? draws : 1); ++d) {
      std::array<Kinematics, 2> noisy = ks;
      std::mt19937_64 rng(1000 + 17 * d + static_cast<uint64_t>(lambda * 100));
      std::normal_distribution<double> g(0.0, sigma * std::sqrt(lambda));
      for (auto& k : noisy)
        for (auto& f : k.frames)
          if (f.valid && lambda > 0)
            for (auto& pt : f.p) pt += Vec2(g(rng), g(rng));
      auto data = PrepareForDiagnosis(noisy, o);
      const double av = data.ok() ? GapOffsetFrom(*data, c, o) : NAN;
      std::printf(" %.3f", av);
      if (std::isfinite(av)) {
        sum += av;
        ++n;
      }
    }
    std::printf(" | %.3f |\n", n ? sum / n : NAN);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
