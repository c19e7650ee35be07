// --drive-check: does processing a noisy recording bias the model driven by it?
#include <cmath>
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int DriveCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions o = b.LowpassOptions();
  const double fps = b.fps, duration = b.duration;
  const Sources& src = b.src;
  // Does the processing of a noisy recording bias the model driven by it? On the
  // `none` cases of the tuning set (no effect injected): the TRUE model's held-out E,
  // and gap_offset's parameter fitted with all blocks from the truth (a > 0: the
  // simulated body moves less than the recorded one), per tracking noise and low-pass
  // cut-off.
  // --coulomb-scale K multiplies both Coulomb coefficients of the truth (K < 1: more
  // viscous bodies), as in --null-check.
  auto cases = MakeCases(11);
  const double mu_scale = Arg(args, "--coulomb-scale", 1.0);
  // --cutoff HZ replaces the two low-pass cut-offs compared (5 and 3 Hz) by one.
  const double cutoff = Arg(args, "--cutoff", 0.0);
  const std::vector<double> cutoffs = cutoff > 0 ? std::vector<double>{cutoff} : std::vector<double>{5.0, 3.0};
  // --noise MM: the second noise level, besides the benchmark's 2 µm.
  const double second_noise = Arg(args, "--noise", 0.0002);
  std::printf(
      "| case | source | noise (mm) | lowpass (Hz) | E true (mm) | gap_offset a | a, clean drive and "
      "shapes | a, clean drive | a, clean shapes |\n|---|---|---|---|---|---|---|---|---|\n");
  for (int i = 0; i < 11; ++i) {
    Case c = cases[i];
    c.coef.mu_n *= mu_scale;
    c.coef.mu_t *= mu_scale;
    const auto clean = Synth(c, src, fps, duration, 0.0);
    for (double noise : {0.002, second_noise}) {
      auto ks = Synth(c, src, fps, duration, noise);
      if (!ks.ok()) continue;
      for (double lp : cutoffs) {
        DiagnoseOptions r = o;
        r.lowpass_hz = lp;
        auto data = PrepareForDiagnosis(*ks, r);
        if (!data.ok()) continue;
        const double a_data = GapOffsetFrom(*data, c.coef, o);
        // The same fit with parts taken from the CLEAN recording, processed alike (the
        // measured positions keep their noise): is it the noisy drive, the noisy body
        // shape of the scored points, or the noisy positions, that biases a?
        // Variant 1: the drive and the shapes from the clean recording; 2: only the
        // drive; 3: only the shapes.
        double a_clean[3] = {NAN, NAN, NAN};
        if (clean.ok())
          if (auto dc = PrepareForDiagnosis(*clean, r); dc.ok())
            for (int v = 0; v < 3; ++v) {
              EffectData mixed = *data;
              bool same = true;
              for (int w = 0; w < 2 && same; ++w) {
                auto& m = mixed.worms[w];
                const auto& cw = dc->worms[w];
                same = m.frames.size() == cw.frames.size();
                if (!same) break;
                if (v != 2) m.drive = cw.drive;
                if (v != 1)
                  for (size_t f = 0; f < m.frames.size(); ++f) m.frames[f].model = cw.frames[f].model;
              }
              if (same) a_clean[v] = GapOffsetFrom(mixed, c.coef, o);
            }
        std::printf("| %llu | %s | %g | %g | %.4g | %.3f | %.3f | %.3f | %.3f |\n",
                    static_cast<unsigned long long>(c.seed), SourceName(c), noise, lp, TrueModelE(*data, c, r.epsilon),
                    a_data, a_clean[0], a_clean[1], a_clean[2]);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
