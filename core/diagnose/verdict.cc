// The verdict and "how far": from the scores already in a Diagnosis, the bar of every
// effect, which effects are significant, the winner or `none`/`unexplained`, the
// explanation, the grade, and the held-out E before and after with bootstrap intervals.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "core/common/stats.h"
#include "core/diagnose/internal/stages.h"

namespace wormdrag::diagnose {
namespace {

using internal::Mean;
using internal::Median;
using internal::Penalised;
using internal::Sd;

// The share of the base model's error that is not noise and that the effect leaves, from
// held-out MSEs on the data (S) and on copies with the noise variance doubled (S_noisy):
// a noise-driven MSE doubles there, model error stays, so model error ≈ 2 S − S_noisy
// (linear extrapolation to no noise). NaN when the base shows no model error.
double SimexResidual(double s0, double s0_noisy, double s1, double s1_noisy) {
  const double base_error = 2 * s0 - s0_noisy;
  if (!(base_error > 0) || !std::isfinite(s1_noisy)) return std::numeric_limits<double>::quiet_NaN();
  return (2 * s1 - s1_noisy) / base_error;
}
// 5 % quantile of the held-out shrink (base − model, mean distance in mm) over
// resamples of the held-out blocks, the same blocks for both (paired).
double PairedShrinkLo(const EffectFit& base, const std::vector<double>& model_sum,
                      const std::vector<double>& model_count, uint64_t seed) {
  const int nb = static_cast<int>(std::min({base.block_sum.size(), model_sum.size(), model_count.size()}));
  if (nb == 0) return 0;
  // A small fast generator (splitmix64): the benchmark's threshold search runs this
  // for every effect of every case at every grid point.
  uint64_t state = seed;
  auto next = [&state]() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  std::vector<double> sh(1000);
  for (double& v : sh) {
    double d = 0, c = 0;
    for (int k = 0; k < nb; ++k) {
      const int i = static_cast<int>(next() % static_cast<uint64_t>(nb));
      d += base.block_sum[i] - model_sum[i];
      c += model_count[i];
    }
    v = c > 0 ? d / c : 0;
  }
  std::nth_element(sh.begin(), sh.begin() + 50, sh.end());
  return sh[50];
}

// gap_offset needs its mark in the base residual, beyond what the noise-only replicates'
// base fits show (DiagnoseOptions::require_gap_signature); every other effect passes. A
// mark that could not be measured (fewer than two runs of missing frames or two windows
// elsewhere), on the data or on two replicates, holds nothing back.
bool ShowsGapSignature(const DiagnoseOptions& o, const Diagnosis& out, const EffectFit& f) {
  const GapSignature& g = out.gap_signature;
  if (f.name != "gap_offset" || !o.require_gap_signature || !g.Measured() || f.params.empty() ||
      !std::isfinite(out.gap_signature_hi))
    return true;
  return f.params[0] > 0 ? g.Z() > out.gap_signature_hi : g.Z() < out.gap_signature_lo;
}

// The gains noise alone produces, relative to each replicate's own base score (reported
// as the effect's null mean and sd): a noise-only refit that scores WORSE than the base
// (the extra freedom overfitted the training blocks) is no evidence of a spurious gain,
// so negative gains count as 0.
void NullGains(const DiagnoseOptions& o, Diagnosis* out) {
  for (EffectFit& f : out->effects) {
    if (!f.testable) continue;
    std::vector<double> ni;
    for (double r : f.null_improvements)
      ni.push_back(std::max(0.0, 1 - r * (1 + o.penalty_per_param * f.extra_params)));
    f.null_mean = Mean(ni);
    f.null_sd = Sd(ni);
  }
}

// The effect's bar on the data's relative gain: the (1 − false_alarm_rate) prediction
// bound of the held-out reduction (mm², base − penalised effect) it reaches on a
// noise-only replicate, over the data's base score. The reduction is absolute because
// noise produces a reduction of a given size, not a share of the data's score: where the
// data's base is far above the noise, the same noise artefact is a small share of it.
// Reductions below 0 count as 0, as the gains do (NullGains).
double NullBar(const DiagnoseOptions& o, const Diagnosis& out, const EffectFit& f) {
  const std::vector<double>& base = out.null_base_cv_mses;
  if (base.size() != f.null_improvements.size()) return std::numeric_limits<double>::infinity();
  std::vector<double> reduction;
  for (size_t r = 0; r < base.size(); ++r)
    reduction.push_back(
        std::max(0.0, base[r] * (1 - f.null_improvements[r] * (1 + o.penalty_per_param * f.extra_params))));
  return PredictionBound(reduction, o.false_alarm_rate) / out.base_cv.cv_mse;
}

// The SIMEX check of effect f (its gain on the noisy copies, extrapolated to no noise, and
// the model error it leaves); false when its gain does not survive the added noise
// (simex_min_keep) or the check is on but did not examine it.
bool SimexKeeps(const DiagnoseOptions& o, const Diagnosis& out, double S0, EffectFit* fp) {
  EffectFit& f = *fp;
  f.simex_gain = 0;
  f.simex_corrected = f.improvement;
  f.simex_residual = std::numeric_limits<double>::quiet_NaN();
  bool kept = true;
  // With the check on, an effect it did not examine (ranked below simex_top) cannot be
  // named: once it rejects the leading effects, the next one would win unchecked.
  const bool simex_on = (o.simex_weight > 0 || o.simex_min_keep > 0) && !out.simex_base_mse.empty();
  if (simex_on && f.simex_mse.size() != out.simex_base_mse.size()) kept = false;
  if (!f.simex_mse.empty() && f.simex_mse.size() == out.simex_base_mse.size()) {
    // The copies score the effect as the data do: by its own fit's folds too when those
    // score it on the data.
    std::vector<double> copy_mse = f.simex_mse;
    if (f.scored_own && f.simex_own_mse.size() == copy_mse.size())
      for (size_t k = 0; k < copy_mse.size(); ++k) copy_mse[k] = std::min(copy_mse[k], f.simex_own_mse[k]);
    // The gain on each copy, absolute: over the data's base score.
    std::vector<double> g;
    for (size_t k = 0; k < copy_mse.size(); ++k) {
      const double gk = (out.simex_base_mse[k] - Penalised(copy_mse[k], f.extra_params, o.penalty_per_param)) / S0;
      if (std::isfinite(gk)) g.push_back(gk);
    }
    if (!g.empty()) {
      f.simex_gain = Median(g);
      f.simex_corrected = f.improvement - o.simex_weight * std::max(0.0, f.simex_gain - f.improvement);
      kept = f.simex_gain >= o.simex_min_keep * f.improvement;
    }
    f.simex_residual = SimexResidual(S0, Median(out.simex_base_mse), f.scored_own ? f.own_cv_mse : f.cv_mse,
                                     Median(copy_mse));
  }
  return kept;
}

// Effect i's score, bar, shrink interval, SIMEX check and significance.
void ScoreEffect(const DiagnoseOptions& o, const Diagnosis& out, size_t i, EffectFit* fp) {
  EffectFit& f = *fp;
  const double S0 = out.base_cv.cv_mse;
  // A refined effect (refine_top) is scored by the better of its base-centred fold fits
  // and those centred on its own free fit: the base-centred ones cannot undo the base's
  // compensation for the missing effect (docs/decisions/0019-own-refit.md).
  f.scored_own = o.score_refined_fit && f.refined && f.own_block_sum.size() == f.block_count.size() &&
                 f.own_cv_mse > 0 && f.own_cv_mse < f.cv_mse;
  f.cv_score = Penalised(f.scored_own ? f.own_cv_mse : f.cv_mse, f.extra_params, o.penalty_per_param);
  f.improvement = 1 - f.cv_score / S0;
  f.threshold = std::max(o.min_improvement, NullBar(o, out, f));
  f.shrink_lo = PairedShrinkLo(out.base_cv, f.scored_own ? f.own_block_sum : f.block_sum, f.block_count, o.seed + i);
  const bool kept = SimexKeeps(o, out, S0, &f);
  f.significant = f.improvement > f.threshold && f.simex_corrected > f.threshold && kept &&
                  (!o.require_shrink_interval || f.shrink_lo > 0) && ShowsGapSignature(o, out, f) &&
                  (!o.require_estimated_params || f.estimated);
}

// How far: held-out E before and after `after` (its own fit's when it was refined), with
// 90 % block-bootstrap intervals, the shrink, and its share of the gap above the floor.
void HowFar(const DiagnoseOptions& o, const EffectFit& after, Diagnosis* dp) {
  Diagnosis& out = *dp;
  auto sum = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); };
  out.e_before = sum(out.base_cv.block_sum) / sum(out.base_cv.block_count);
  const bool own = o.refine_top > 0 && after.refined && after.own_block_sum.size() == after.block_count.size();
  const std::vector<double>& after_sum = own ? after.own_block_sum : after.block_sum;
  out.e_after = sum(after_sum) / sum(after.block_count);
  std::mt19937_64 rng(o.seed);
  const int nb = static_cast<int>(after_sum.size());
  std::uniform_int_distribution<int> pick(0, nb - 1);
  std::vector<double> eb, ea, sh;
  for (int it = 0; it < 2000; ++it) {
    double s0 = 0, s1 = 0, c = 0;
    for (int k = 0; k < nb; ++k) {
      const int i = pick(rng);
      s0 += out.base_cv.block_sum[i];
      s1 += after_sum[i];
      c += after.block_count[i];
    }
    eb.push_back(s0 / c);
    ea.push_back(s1 / c);
    sh.push_back((s0 - s1) / c);
  }
  auto q = [](std::vector<double> v, double p) {
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<size_t>(p * v.size()))];
  };
  out.e_before_lo = q(eb, 0.05);
  out.e_before_hi = q(eb, 0.95);
  out.e_after_lo = q(ea, 0.05);
  out.e_after_hi = q(ea, 0.95);
  out.shrink_mm = out.e_before - out.e_after;
  out.shrink_lo = q(sh, 0.05);
  out.shrink_hi = q(sh, 0.95);
  const double gap = out.e_before - out.null_base_cv_e;
  out.share_of_gap = gap > 0 ? out.shrink_mm / gap : 0.0;
}

// Why there is a gap, in the words that open an `unexplained` explanation: the held-out
// blocks, or else the full path, which the blocks' restarts hide.
std::string GapText(const Diagnosis& out) {
  char buf[400];
  if (out.gap_beyond_noise)
    std::snprintf(buf, sizeof buf, "The gap is beyond tracking noise (held-out E %.4g mm vs %.4g mm from noise alone).",
                  out.e_before, out.null_base_cv_e);
  else
    std::snprintf(buf, sizeof buf,
                  "The base model's full path drifts beyond tracking noise (RMS distance %.4g mm vs %.4g mm in the "
                  "noise-only refits), although its held-out blocks, each restarted on the measured pose, stay "
                  "within the test's bound (%.4g mm vs %.4g mm): the misfit accumulates along the path.",
                  std::sqrt(out.path_mse), std::sqrt(out.null_path_mse), out.e_before, out.null_base_cv_e);
  return buf;
}

// The rate of each of the gap's two tests (held-out blocks, full path): half the
// false-alarm rate, so that their union keeps it (Bonferroni).
double GapTestRate(const DiagnoseOptions& o) {
  return o.false_alarm_rate / 2;
}

// The explanation of `none`. It says why "where" cells marked above noise (beyond the
// refits' prediction bound) make no gap, so that the table and the verdict do not contradict
// each other.
std::string NoGap(const DiagnoseOptions& o, const Diagnosis& out) {
  char buf[1000];
  const double level = 100 * (1 - GapTestRate(o));
  if (out.null_path_mse > 0)
    std::snprintf(buf, sizeof buf,
                  "No significant gap beyond tracking noise: neither the base model's held-out error (%.4g mm) nor "
                  "its full path (RMS distance %.4g mm) lies above the %.1f %% prediction bound of what noise of "
                  "%.3g mm alone gives in the noise-only refits (mean %.4g mm and %.4g mm), and no catalogue effect "
                  "improves it by more than it does on noise-only data.",
                  out.e_before, std::sqrt(out.path_mse), level, out.noise_sigma, out.null_base_cv_e,
                  std::sqrt(out.null_path_mse));
  else
    std::snprintf(buf, sizeof buf,
                  "No significant gap beyond tracking noise: the base model's held-out error (%.4g mm) does not lie "
                  "above the %.1f %% prediction bound of what noise of %.3g mm alone gives in the noise-only refits "
                  "(mean %.4g mm), and no catalogue effect improves it by more than it does on noise-only data.",
                  out.e_before, level, out.noise_sigma, out.null_base_cv_e);
  std::string s = buf;
  bool above = false;
  for (const auto& w : out.where)
    for (const auto& c : w.cells) above = above || c.above_noise();
  if (above && out.null_path_mse > 0)
    s += " The \"where\" cells marked above noise lie beyond the refits' prediction bound, which marks them but makes "
         "no gap: the whole path stays within the bound above.";
  return s;
}

// No significant effect: `none` or `unexplained`, naming the closest effect, and the
// explanation says which rule stopped it.
std::string NoEffect(const DiagnoseOptions& o, int closest, Diagnosis* dp) {
  Diagnosis& out = *dp;
  char buf[1000];
  out.verdict = out.gap_beyond_noise || out.path_beyond_noise ? "unexplained" : "none";
  const std::string gap = GapText(out);
  const EffectFit* c = closest >= 0 ? &out.effects[closest] : nullptr;
  if (c) out.closest = c->name;
  if (out.verdict == "none") return NoGap(o, out);
  if (c && c->improvement > c->threshold && !c->simex_mse.empty() && c->simex_gain < o.simex_min_keep * c->improvement)
    std::snprintf(
        buf, sizeof buf,
        "%s The closest catalogue effect, %s, gains %.2f, but only %.2f when tracking noise is added to the "
        "data: a property of the body would keep its gain, so this one fits the chance pattern of this recording "
        "rather than an effect.",
        gap.c_str(), c->name.c_str(), c->improvement, c->simex_gain);
  else if (c && c->improvement > c->threshold && !ShowsGapSignature(o, out, *c))
    std::snprintf(buf, sizeof buf,
                  "%s The closest catalogue effect, gap_offset, gains %.2f, but the base fit's residual does not "
                  "jump where frames are missing (%.3g +- %.2g times the model's displacement there beyond "
                  "elsewhere, z = %.1f, within the %.1f … %.1f that noise alone reaches in the noise-only refits "
                  "or on the other side than the fitted a): its gain comes from scaling the path as a whole, not "
                  "from the dropped frames.",
                  gap.c_str(), c->improvement, out.gap_signature.excess, out.gap_signature.se, out.gap_signature.Z(),
                  out.gap_signature_lo, out.gap_signature_hi);
  else if (c && c->improvement > c->threshold && o.require_estimated_params && !c->estimated)
    std::snprintf(
        buf, sizeof buf,
        "%s The closest catalogue effect, %s, gains %.2f, but its fits left its parameter where they started (%s "
        "= %.4g): the data did not estimate it, so the effect is not named.",
        gap.c_str(), c->name.c_str(), c->improvement, c->param_names.empty() ? "" : c->param_names[0].c_str(),
        c->params.empty() ? 0.0 : c->params[0]);
  else if (c && c->improvement > c->threshold && !(c->simex_corrected > c->threshold))
    std::snprintf(buf, sizeof buf,
                  "%s The closest catalogue effect, %s, gains %.2f, but %.2f when tracking noise is added to the "
                  "data: a gain that grows with the noise is a bias of the noisy drive rather than an effect "
                  "(extrapolated to no noise it is %.2f, below its bar of %.2f).",
                  gap.c_str(), c->name.c_str(), c->improvement, c->simex_gain, c->simex_corrected, c->threshold);
  else if (closest >= 0 && out.effects[closest].threshold >= 1)
    // Noise-only refits that gain this much leave a bar no effect can clear: say so
    // rather than suggest the effect was tested and failed.
    std::snprintf(buf, sizeof buf,
                  "%s The closest catalogue effect, %s, changes held-out E by %.3g mm (%.0f %% of the gap above "
                  "the noise floor), but its noise-only refits vary so much that its bar (%.2f) is above 1: no "
                  "gain could be significant on this pair.",
                  gap.c_str(), out.closest.c_str(), out.shrink_mm, 100 * out.share_of_gap,
                  out.effects[closest].threshold);
  else
    std::snprintf(buf, sizeof buf,
                  "%s No catalogue effect explains it significantly; the closest, %s, changes held-out E by %.3g mm.",
                  gap.c_str(), out.closest.c_str(), out.shrink_mm);
  return buf;
}

// The winner `best`: named alone, in a set of ties, or `unexplained` when it removes too
// little of the gap; a named verdict is graded clear or tentative.
std::string Named(const DiagnoseOptions& o, int best, Diagnosis* dp) {
  Diagnosis& out = *dp;
  char buf[1000];
  const EffectFit& b = out.effects[best];
  const double S0 = out.base_cv.cv_mse;
  for (const auto& f : out.effects)
    if (f.significant && f.cv_score - b.cv_score <= o.tie_fraction * (S0 - b.cv_score))
      out.verdict_set.push_back(f.name);
  const double excess_share = out.share_of_gap;
  if (excess_share < o.explained_share && out.gap_beyond_noise) {
    out.verdict = "unexplained";
    out.closest = b.name;
    std::snprintf(buf, sizeof buf,
                  "The gap is beyond tracking noise; %s is the best catalogue effect but removes only %.0f %% of the "
                  "held-out gap above the noise floor, so the gap is not explained by the catalogue.",
                  b.name.c_str(), 100 * excess_share);
  } else if (out.verdict_set.size() > 1) {
    std::string s;
    for (const auto& n : out.verdict_set) s += (s.empty() ? "" : "|") + n;
    out.verdict = s;
    std::snprintf(buf, sizeof buf,
                  "Several effects explain the gap about equally well (%s); the data cannot tell them apart. The "
                  "best, %s, shrinks held-out E from %.4g to %.4g mm.",
                  s.c_str(), b.name.c_str(), out.e_before, out.e_after);
  } else {
    out.verdict = b.name;
    const std::string ps = ParameterText(b);
    std::snprintf(buf, sizeof buf,
                  "%s explains the gap: %s. Held-out E falls from %.4g mm to %.4g mm (%.0f %% of the gap above the "
                  "noise floor of %.4g mm).",
                  b.name.c_str(), ps.c_str(), out.e_before, out.e_after, 100 * out.share_of_gap, out.null_base_cv_e);
  }
  if (out.verdict != "unexplained") {
    out.margin = std::min(b.improvement, b.simex_corrected) / b.threshold;
    out.confidence = out.margin >= o.clear_margin ? "clear" : "tentative";
    if (out.confidence == "tentative") {
      const size_t n = std::strlen(buf);
      std::snprintf(buf + n, sizeof buf - n,
                    " Tentative: its gain is only %.2f times the bar that noise-only refits set (a clear verdict "
                    "needs %.3g times); an effect outside the catalogue can score like this.",
                    out.margin, o.clear_margin);
    }
  }
  return buf;
}

}  // namespace

double internal::NoiseBound(double alpha, const std::vector<double>& null) {
  std::vector<double> logs;
  for (double v : null)
    if (v > 0) logs.push_back(std::log(v));
  return std::exp(PredictionBound(logs, alpha));
}

void Decide(const DiagnoseOptions& o, Diagnosis* dp) {
  Diagnosis& out = *dp;
  const double S0 = out.base_cv.cv_mse;
  out.verdict.clear();
  out.verdict_set.clear();
  out.closest.clear();
  out.confidence.clear();
  out.margin = 0;
  // The gap is the union of two tests, which together keep the rate on a right null
  // (docs/decisions/0049-one-rate-for-the-gap.md).
  const double gap_rate = GapTestRate(o);
  out.noise_bound_cv_mse = internal::NoiseBound(gap_rate, out.null_base_cv_mses);
  out.noise_bound_path_mse = internal::NoiseBound(gap_rate, out.null_path_mses);
  out.gap_beyond_noise = S0 > out.noise_bound_cv_mse;
  out.path_beyond_noise = out.path_mse > out.noise_bound_path_mse;
  // The mark's z is not centred on 0 without the effect, nor standard normal: its
  // standard error leaves out the residual's correlation along the path, and the
  // replicates' own fits shift it. Their prediction interval takes both from them.
  // The interval is symmetric about the replicates' mean.
  out.gap_signature_hi = PredictionBound(out.null_gap_z, o.false_alarm_rate / 2);
  out.gap_signature_lo = 2 * Summarize(out.null_gap_z).mean - out.gap_signature_hi;
  NullGains(o, &out);
  int best = -1, closest = -1;
  for (size_t i = 0; i < out.effects.size(); ++i) {
    EffectFit& f = out.effects[i];
    if (!f.testable) continue;
    ScoreEffect(o, out, i, &f);
    if (f.significant && (best < 0 || f.cv_score < out.effects[best].cv_score)) best = static_cast<int>(i);
    if (closest < 0 || f.cv_score < out.effects[closest].cv_score) closest = static_cast<int>(i);
  }
  const int shown = best >= 0 ? best : closest;
  HowFar(o, shown >= 0 ? out.effects[shown] : out.base_cv, &out);
  out.explanation = best < 0 ? NoEffect(o, closest, &out) : Named(o, best, &out);
  if (out.verdict_set.empty() && out.verdict != "none" && out.verdict != "unexplained") out.verdict_set = {out.verdict};
}

}  // namespace wormdrag::diagnose
