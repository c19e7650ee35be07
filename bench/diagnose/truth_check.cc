// --truth-check: what the processing alone costs the TRUE model of every kymogram pair,
// for kymogram truths low-passed at several cut-offs.
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int TruthCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions o = b.LowpassOptions();
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // What the processing alone costs the TRUE model (known coefficients and effect,
  // nothing fitted): its held-out E on noise-free recordings, with the 5 Hz low-pass and
  // without, for kymogram truths low-passed at several cut-offs first
  // (docs/decisions/0026-benchmark-kymogram-cutoff.md). Cases: every kymogram pair of seed
  // set --score-seed.
  const std::vector<double> cutoffs = {0, 4, 3, 2.5, 2};
  std::vector<Sources> by_cutoff;
  for (double k : cutoffs) {
    auto s = LoadSources(k);
    if (!s.ok()) {
      std::fprintf(stderr, "%s\n", s.status().ToString().c_str());
      return 1;
    }
    s->gap_every_s = src.gap_every_s;
    by_cutoff.push_back(std::move(*s));
  }
  std::printf(
      "| case | truth | E true, no low-pass / %g Hz low-pass (um), kymogram raw | 4 Hz | 3 Hz | 2.5 Hz | 2 Hz |\n"
      "|---|---|---|---|---|---|---|\n",
      o.lowpass_hz);
  for (const Case& c : MakeCases(static_cast<uint64_t>(Arg(args, "--score-seed", 23)))) {
    if (!c.source) continue;
    std::printf("| %d | %s %d |", static_cast<int>(c.seed % 1000), c.effect.c_str(), c.strength);
    for (const Sources& s : by_cutoff) {
      auto clean = Synth(c, s, fps, duration, 0.0);
      double e[2] = {NAN, NAN};
      for (int f = 0; f < 2 && clean.ok(); ++f) {
        DiagnoseOptions r = o;
        r.lowpass_hz = f ? o.lowpass_hz : 0;
        auto data = PrepareForDiagnosis(*clean, r);
        if (data.ok()) e[f] = 1e3 * TrueModelE(*data, c, r.epsilon);
      }
      std::printf(" %.2f / %.2f |", e[0], e[1]);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
