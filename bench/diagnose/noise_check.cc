// --noise-check: the TRUE model of an effect at several noise levels, knot rates and
// without pose restarts.
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int NoiseCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // What tracking noise, the knots and the pose restarts cost the TRUE model of an effect
  // (known coefficients and parameters, nothing fitted): its held-out E with 0, 0.2 and
  // 2 µm of noise, noise-free at 4x the fit's knots and on the continuous path, on the
  // pairs of set --score-seed whose truth is --effect, beside the `none` pairs (the
  // floor). Asks whether an effect's model fails on its own pairs because of its solver,
  // its drive or the noise (docs/decisions/0025-stiction-least-root.md).
  const std::string effect = ArgS(args, "--effect", "stiction");
  std::printf(
      "| case | truth | E true (um): noise 0 | 0.2 um | 2 um | noise 0, %d knots per fitted frame | noise 0, "
      "no pose restarts |\n|---|---|---|---|---|---|---|\n",
      4 * o.substeps);
  for (const Case& c : MakeCases(static_cast<uint64_t>(Arg(args, "--score-seed", 23)))) {
    if (c.effect != effect && c.effect != "none") continue;
    std::printf("| %d | %s %d |", static_cast<int>(c.seed % 1000), c.effect.c_str(), c.strength);
    const auto clean = Synth(c, src, fps, duration, 0.0);  // columns 0, 3 and 4
    for (int k = 0; k < 5; ++k) {
      DiagnoseOptions r = o;
      if (k == 3) r.substeps = 4 * o.substeps;
      const auto ks = k == 1 || k == 2 ? Synth(c, src, fps, duration, k == 1 ? 0.0002 : 0.002) : clean;
      auto data = ks.ok() ? PrepareForDiagnosis(*ks, r) : Result<EffectData>(ks.status());
      // k = 4: the continuous path from the first frame (no pose restarts).
      const double e = data.ok() ? TrueModelE(*data, c, r.epsilon, nullptr, k < 4) : NAN;
      std::printf(" %.2f |", 1e3 * e);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
