// --resolution: the fits' discretisation error, as the TRUE model's held-out E at several
// fit resolutions.
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int ResolutionCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // The fits' discretisation error: held-out E of the TRUE model (no fitting) on
  // noise-free and on noisy data, for several fit resolutions. On noise-free data it
  // is the error of the fit's time resolution alone (and of the 5 Hz filter).
  const int ncases = static_cast<int>(Arg(args, "--cases", 6));
  auto cases = MakeCases(11);
  std::printf(
      "| case | fit_hz | substeps | knots/s | E true clean (mm) | E true noisy (mm) |\n|---|---|---|---|---|---|\n");
  for (int i = 0; i < ncases; ++i) {
    const Case& c = cases[(i * 7 + 3) % cases.size()];
    auto clean = Synth(c, src, fps, duration, 0.0), noisy = Synth(c, src, fps, duration);
    if (!clean.ok() || !noisy.ok()) continue;
    for (double fh : {0.0, 150.0, 100.0, 60.0, 30.0, 20.0})
      for (int ss : {1, 2, 4}) {
        if (fh > 0 && fh >= fps) continue;
        DiagnoseOptions r = o;
        r.fit_hz = fh;
        r.substeps = ss;
        double e[2] = {NAN, NAN};
        for (int n = 0; n < 2; ++n) {
          auto data = PrepareForDiagnosis(n ? *noisy : *clean, r);
          if (data.ok()) e[n] = TrueModelE(*data, c, r.epsilon);
        }
        std::printf("| %s/%d %s | %g | %d | %g | %.3g | %.3g |\n", c.effect.c_str(), c.strength, SourceName(c),
                    fh > 0 ? fh : fps, ss, (fh > 0 ? fh : fps) * ss, e[0], e[1]);
        std::fflush(stdout);
      }
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
