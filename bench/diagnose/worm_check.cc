// --worm-check SEED: an effect fitted with one parameter for both worms and with one per
// worm.
#include <cstdio>
#include <optional>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int WormCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& o = b.o;
  // Does an effect act alike on both worms? The blocked base fit from the start, then
  // effect E (--effect, default time_drift) fitted on all blocks with one parameter
  // for both worms and with one per worm; training MSE of each and the parameters.
  auto e = ParseEffectName(ArgS(args, "--effect", "time_drift"));
  if (!e.ok()) {
    std::fprintf(stderr, "%s\n", e.status().ToString().c_str());
    return 2;
  }
  Case c;
  std::array<Kinematics, 2> ks;
  if (int rc = SynthCaseOf(b, "--worm-check", &c, &ks)) return rc;
  auto data = PrepareForDiagnosis(ks, o);
  if (!data.ok()) {
    std::fprintf(stderr, "%s\n", data.status().ToString().c_str());
    return 1;
  }
  FitSpec fs;
  fs.start = o.start;
  fs.extra_starts = BaseStarts(o.start);
  fs.iterations = o.base_iterations;
  fs.threads = o.threads;
  auto base = FitModel(*data, fs);
  if (!base.ok()) {
    std::fprintf(stderr, "%s\n", base.status().ToString().c_str());
    return 1;
  }
  double true_mse = 0;
  TrueModelE(*data, c, o.epsilon, &true_mse);
  std::printf("case %d: %s strength %d; true model mse %.4g; base mse %.4g\n", static_cast<int>(c.seed),
              c.effect.c_str(), c.strength, true_mse, base->train_mse);
  for (int parity = -1; parity < 2; ++parity) {
    std::optional<FitOutcome> joint;
    for (bool split : {false, true}) {
      FitSpec f;
      f.has_effect = true;
      f.effect = *e;
      f.effect_starts = split ? std::vector<std::vector<double>>{joint->params} : EffectStarts(*e);
      f.per_worm = split;
      f.start = split ? joint->coef : base->coef;
      f.train_parity = parity;
      f.iterations = o.grg_iterations;
      f.threads = o.threads;
      auto r = FitModel(*data, f);
      if (!r.ok()) {
        std::printf("%s\n", r.status().ToString().c_str());
        break;
      }
      if (!split) joint = *r;
      std::printf("  blocks %-4s %-8s train mse %.4g  params",
                  parity < 0    ? "all"
                  : parity == 0 ? "even"
                                : "odd",
                  split ? "per worm" : "shared", r->train_mse);
      for (double v : r->params) std::printf(" %.4g", v);
      std::printf("\n");
    }
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
