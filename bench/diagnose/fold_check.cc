// --fold-check SEED: where the CV's base fold fits land, from its start, from the truth
// and from the leading effects' fits.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int FoldCheck(const Bench& b) {
  const DiagnoseOptions& o = b.o;
  // Where do the CV's base fold fits land? After the diagnosis of a case: each fold's
  // base fit from the CV's start (the blocked base refit), from the true coefficients,
  // and from the coefficients of the two leading effects' fold fits; training objective
  // and held-out MSE of each, next to the effect fits' and the true model's.
  Case c;
  std::array<Kinematics, 2> ks;
  if (int rc = SynthCaseOf(b, "--fold-check", &c, &ks)) return rc;
  auto d = RunDiagnosis(ks, {"worm1", "worm2"}, o);
  if (!d.ok()) {
    std::fprintf(stderr, "%s\n", d.status().ToString().c_str());
    return 1;
  }
  auto data = PrepareForDiagnosis(ks, o);
  if (!data.ok()) {
    std::fprintf(stderr, "%s\n", data.status().ToString().c_str());
    return 1;
  }
  std::printf("case %d: %s strength %d, verdict %s; base CV mse %.3g, floor %.3g\n", static_cast<int>(c.seed),
              c.effect.c_str(), c.strength, d->verdict.c_str(), d->base_cv.cv_mse, d->null_base_cv_mse);
  const double ridge = o.cv_ridge * std::sqrt(2.0) * d->noise_sigma;
  auto held_out = [&](const Coefficients& k, const EffectParams& p, int parity) {
    const BlockScores s = ScoreBlocks(*data, k, p, true, o.epsilon);
    double a2 = 0, n = 0;
    for (size_t i = 0; i < s.sum.size(); ++i)
      if (static_cast<int>(i % data->blocks) % 2 != parity) {
        a2 += s.sum_sq[i];
        n += s.count[i];
      }
    return a2 / n;
  };
  std::vector<const EffectFit*> lead;
  for (const auto& e : d->effects)
    if (e.testable) lead.push_back(&e);
  std::sort(lead.begin(), lead.end(), [](auto* a, auto* b) { return a->cv_score < b->cv_score; });
  if (lead.size() > 2) lead.erase(lead.begin() + 2, lead.end());
  for (int parity = 0; parity < 2; ++parity) {
    auto fit = [&](bool has_effect, Effect e, const Coefficients& start,
                   const char* what) -> std::optional<FitOutcome> {
      FitSpec fs;
      fs.has_effect = has_effect;
      fs.effect = e;
      if (has_effect) fs.effect_starts = EffectStarts(e);
      fs.start = start;
      fs.prior = d->cv_base;
      fs.prior_weight = ridge;
      fs.train_parity = parity;
      fs.iterations = o.grg_iterations;
      fs.epsilon = o.epsilon;
      fs.threads = o.threads;
      auto r = FitModel(*data, fs);
      if (!r.ok()) {
        std::printf("  fold %d %s: %s\n", parity, what, r.status().ToString().c_str());
        return std::nullopt;
      }
      std::printf("  fold %d %-34s train %.4g held-out %.4g  coef %.3g %.3g %.3g %.3g\n", parity, what, r->train_mse,
                  held_out(r->coef, r->effects, parity), r->coef.mu_n, r->coef.mu_t, r->coef.eta_n, r->coef.eta_t);
      return *r;
    };
    std::printf("  fold %d %-34s                held-out %.4g\n", parity, "true model (no fit)",
                held_out(c.coef, c.truth, parity));
    fit(false, Effect::kBodyGradient, d->cv_base, "base from the CV start");
    fit(false, Effect::kBodyGradient, c.coef, "base from the true coefficients");
    for (const EffectFit* e : lead) {
      const Effect ef = *ParseEffectName(e->name);
      auto ef_fit = fit(true, ef, d->cv_base, (e->name + " from the CV start").c_str());
      if (ef_fit) fit(false, Effect::kBodyGradient, ef_fit->coef, ("base from " + e->name + "'s fit").c_str());
    }
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
