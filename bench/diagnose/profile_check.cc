// --profile-check: held-out E of an effect's model along its parameter at the true
// coefficients.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int ProfileCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // Held-out E (µm) of an effect's model along its first parameter, the coefficients at
  // the truth, on the pairs of set --score-seed whose truth is --effect: coarse over the
  // admissible range, then fine around the truth. The fits' GRG differentiates with
  // steps of 1e-3 of a grid unit, so a profile jagged on the fine scale leaves it at its
  // start (docs/decisions/0023-unestimated-parameters.md).
  const std::string effect = ArgS(args, "--effect", "stiction");
  const auto ef = ParseEffectName(effect);
  if (!ef.ok()) {
    std::fprintf(stderr, "%s\n", ef.status().ToString().c_str());
    return 2;
  }
  for (const Case& c : MakeCases(static_cast<uint64_t>(Arg(args, "--score-seed", 23)))) {
    if (c.effect != effect) continue;
    const auto ks = Synth(c, src, fps, duration, Arg(args, "--noise", 0.002));
    auto data = ks.ok() ? PrepareForDiagnosis(*ks, o) : Result<EffectData>(ks.status());
    if (!data.ok()) {
      std::fprintf(stderr, "%s\n", data.status().ToString().c_str());
      continue;
    }
    const std::vector<double> truth = GetParams(c.truth, *ef);
    const EffectInfo& info = InfoOf(*ef);
    auto e_at = [&](double v) {
      Case m = c;
      std::vector<double> x = truth;
      x[0] = v;
      SetParams(&m.truth, *ef, x);
      return 1e3 * TrueModelE(*data, m, o.epsilon);
    };
    std::printf("%d %s=%g, coarse:", static_cast<int>(c.seed % 1000), effect.c_str(), truth[0]);
    const double lo = info.lower[0], hi = std::min(info.upper[0], 3 * std::abs(truth[0]) + 1);
    for (int i = 0; i <= 12; ++i) {
      const double v = lo + (hi - lo) * i / 12;
      std::printf(" %.3g:%.2f", v, e_at(v));
    }
    std::printf("\n    fine:");
    for (int i = -5; i <= 5; ++i) std::printf(" %.3g:%.3f", truth[0] + 0.01 * i, e_at(truth[0] + 0.01 * i));
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
