// --fit-check SEED: does the base fit reach the truth, and the case's effect?
#include <cstdio>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int FitCheck(const Bench& b) {
  const DiagnoseOptions& o = b.o;
  // Does the base fit reach the truth? Blocked fits on all blocks (as the CV's) from
  // the true coefficients and from the default start; training MSE of each and of the
  // true model itself.
  Case c;
  std::array<Kinematics, 2> ks;
  if (int rc = SynthCaseOf(b, "--fit-check", &c, &ks)) return rc;
  auto data = PrepareForDiagnosis(ks, o);
  if (!data.ok()) {
    std::fprintf(stderr, "%s\n", data.status().ToString().c_str());
    return 1;
  }
  Coefficients fitted = o.start;  // the blocked fit from the start
  for (bool blocked : {true, false})
    for (int from = 0; from < 3; ++from) {
      FitSpec fs;
      fs.start = from == 0 ? c.coef : o.start;
      if (from == 2) fs.extra_starts = BaseStarts(o.start);
      fs.blocked = blocked;
      fs.iterations = from == 0 ? 1 : o.base_iterations;
      fs.threads = o.threads;
      auto r = FitModel(*data, fs);
      if (!r.ok()) {
        std::printf("%s\n", r.status().ToString().c_str());
        continue;
      }
      if (blocked && from == 1) fitted = r->coef;
      std::printf("%s from %s: train mse %.4g after %ld evaluations, coef %.4g %.4g %.4g %.4g\n",
                  blocked ? "blocked" : "continuous",
                  from == 0   ? "truth (1 iteration)"
                  : from == 1 ? "start"
                              : "9 starts",
                  r->train_mse, r->evaluations, r->coef.mu_n, r->coef.mu_t, r->coef.eta_n, r->coef.eta_t);
    }
  if (c.category == "catalogue") {
    // The case's own effect, blocked, all blocks: from its neutral start(s) and from the truth.
    const Effect e = *ParseEffectName(c.effect);
    // The third variant (neutral and ±0.8) only for one-parameter effects whose range holds it.
    const EffectInfo& info = InfoOf(e);
    const bool pm = info.params.size() == 1 && info.lower[0] <= -0.8 && info.upper[0] >= 0.8;
    for (int from = 0; from < 6; ++from) {
      if (from % 3 == 2 && !pm) continue;
      FitSpec fs;
      fs.has_effect = true;
      fs.effect = e;
      fs.effect_starts = from % 3 == 1 ? std::vector<std::vector<double>>{GetParams(c.truth, e)} : EffectStarts(e);
      if (from % 3 == 2) fs.effect_starts = {{0.0}, {0.8}, {-0.8}};
      fs.start = from < 3 ? c.coef : fitted;
      fs.iterations = o.grg_iterations;
      fs.threads = o.threads;
      auto r = FitModel(*data, fs);
      if (!r.ok()) {
        std::printf("%s\n", r.status().ToString().c_str());
        continue;
      }
      std::printf("%s from %s (coefficients from the %s, %d iterations): train mse %.4g, param %.4g\n",
                  c.effect.c_str(),
                  from % 3 == 0   ? "its diagnosis starts"
                  : from % 3 == 1 ? "its true value"
                                  : "0, ±0.8",
                  from < 3 ? "truth" : "blocked base fit", o.grg_iterations, r->train_mse, r->params[0]);
    }
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
