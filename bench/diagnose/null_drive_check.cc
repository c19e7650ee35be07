// --null-drive-check: do the noise-only replicates carry the data's processing bias?
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int NullDriveCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions o = b.LowpassOptions();
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // Do the noise-only replicates carry the data's processing bias? On the `none` cases
  // of the tuning set (2 µm noise, the diagnosis's low-pass): gap_offset fitted with
  // all blocks from the TRUE coefficients on the data, and on replicates made as the
  // diagnosis makes them (truth = the true model on the data's processed drive, plus
  // noise, processed again) but with the replicates' truth driven by the data's angles
  // low-passed at other cut-offs, or by the clean recording's (the ideal).
  auto cases = MakeCases(11);
  const double sigma = Arg(args, "--noise", 0.002);
  const int reps = std::max(1, static_cast<int>(Arg(args, "--reps", 2)));
  const std::vector<double> truth_cutoffs = {o.lowpass_hz, 3.0, 2.0};
  std::printf("| case | source | a, data |");
  for (double hz : truth_cutoffs) std::printf(" a, replicates (truth %g Hz) |", hz);
  std::printf(" a, replicates (clean truth) |\n|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    if (c.category != "none") continue;
    auto ks = Synth(c, src, fps, duration, sigma), clean = Synth(c, src, fps, duration, 0.0);
    if (!ks.ok() || !clean.ok()) continue;
    auto d = PrepareForDiagnosis(*ks, o);
    if (!d.ok()) continue;
    std::printf("| %d | %s | %.3f |", static_cast<int>(c.seed % 1000), SourceName(c), GapOffsetFrom(*d, c.coef, o));
    for (int v = 0; v <= static_cast<int>(truth_cutoffs.size()); ++v) {
      DiagnoseOptions to = o;
      if (v < static_cast<int>(truth_cutoffs.size())) to.lowpass_hz = truth_cutoffs[v];
      auto truth = PrepareForDiagnosis(v < static_cast<int>(truth_cutoffs.size()) ? *ks : *clean, to);
      double a = 0;
      int n = 0;
      for (int r = 1; truth.ok() && r <= reps; ++r) {
        auto rec = NullPair(*truth, c.coef, o.epsilon, sigma, r);
        if (!rec.ok()) continue;
        auto rd = PrepareForDiagnosis(*rec, o);
        if (!rd.ok()) continue;
        const double ar = GapOffsetFrom(*rd, c.coef, o);
        if (std::isfinite(ar)) {
          a += ar;
          ++n;
        }
      }
      std::printf(" %.3f |", n > 0 ? a / n : NAN);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
