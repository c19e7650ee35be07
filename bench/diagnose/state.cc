// The saved state of a run: one JSON line per outcome with what Decide and the report
// need (--state), read back by --redecide; and the one-line summary of an outcome.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {
namespace {

// A number as the state wrote it: JSON has no NaN, and a NaN was written as null.
double Num(const nlohmann::json& j, const char* key) {
  const nlohmann::json& v = j.at(key);
  return v.is_null() ? NAN : v.get<double>();
}
std::vector<double> Nums(const nlohmann::json& j, const char* key) {
  std::vector<double> out;
  for (const nlohmann::json& v : j.at(key)) out.push_back(v.is_null() ? NAN : v.get<double>());
  return out;
}

nlohmann::json GapSignatureJson(const GapSignature& g) {
  return {{"gaps", g.gaps},           {"windows", g.windows}, {"at_gaps", g.at_gaps},
          {"elsewhere", g.elsewhere}, {"excess", g.excess},   {"se", g.se}};
}
GapSignature GapSignatureOf(const nlohmann::json& j) {
  GapSignature g;
  g.gaps = j.at("gaps");
  g.windows = j.at("windows");
  g.at_gaps = Num(j, "at_gaps");
  g.elsewhere = Num(j, "elsewhere");
  g.excess = Num(j, "excess");
  g.se = Num(j, "se");
  return g;
}

}  // namespace

nlohmann::json StateOf(const std::string& set, const Outcome& x) {
  auto fit = [](const EffectFit& f) {
    return nlohmann::json{{"name", f.name},
                          {"param_names", f.param_names},
                          {"extra_params", f.extra_params},
                          {"testable", f.testable},
                          {"params", f.params},
                          {"param_lo", f.param_lo},
                          {"param_hi", f.param_hi},
                          {"null_param_sd", f.null_param_sd},
                          {"cv_mse", f.cv_mse},
                          {"cv_e_mm", f.cv_e_mm},
                          {"block_sum", f.block_sum},
                          {"block_count", f.block_count},
                          {"null_improvements", f.null_improvements},
                          {"refined", f.refined},
                          {"own_cv_mse", f.own_cv_mse},
                          {"own_cv_e_mm", f.own_cv_e_mm},
                          {"own_block_sum", f.own_block_sum},
                          {"simex_mse", f.simex_mse},
                          {"simex_own_mse", f.simex_own_mse},
                          {"estimated", f.estimated}};
  };
  nlohmann::json effects = nlohmann::json::array();
  for (const auto& f : x.d.effects) effects.push_back(fit(f));
  return {{"set", set},
          {"seed", x.c.seed},
          {"ok", x.ok},
          {"error", x.error},
          {"e_true", x.e_true},
          {"mse_true", x.mse_true},
          {"mse_fitted_truth", x.mse_fitted_truth},
          {"e_fitted_truth", x.e_fitted_truth},
          {"seconds", x.seconds},
          {"noise_sigma", x.d.noise_sigma},
          {"null_base_cv_mse", x.d.null_base_cv_mse},
          {"null_base_cv_sd", x.d.null_base_cv_sd},
          {"null_base_cv_e", x.d.null_base_cv_e},
          {"null_base_cv_mses", x.d.null_base_cv_mses},
          {"path_mse", x.d.path_mse},
          {"null_path_mse", x.d.null_path_mse},
          {"null_path_sd", x.d.null_path_sd},
          {"null_path_mses", x.d.null_path_mses},
          {"simex_base_mse", x.d.simex_base_mse},
          {"base_cv", fit(x.d.base_cv)},
          {"effects", effects},
          {"gap_signature", GapSignatureJson(x.d.gap_signature)},
          {"null_gap_z", x.d.null_gap_z}};
}

bool OutcomeOf(const nlohmann::json& j, Outcome* out) {
  Outcome& x = *out;
  if (!CaseBySeed(j.at("seed").get<uint64_t>(), &x.c)) return false;
  x.ok = j.at("ok");
  x.error = j.at("error");
  x.e_true = Num(j, "e_true");
  x.mse_true = Num(j, "mse_true");
  x.mse_fitted_truth = Num(j, "mse_fitted_truth");
  x.e_fitted_truth = Num(j, "e_fitted_truth");
  x.seconds = Num(j, "seconds");
  x.d.noise_sigma = Num(j, "noise_sigma");
  x.d.null_base_cv_mse = Num(j, "null_base_cv_mse");
  x.d.null_base_cv_sd = Num(j, "null_base_cv_sd");
  x.d.null_base_cv_e = Num(j, "null_base_cv_e");
  // States written before the full-path gap test have no full path: the test is off there.
  x.d.path_mse = j.contains("path_mse") ? Num(j, "path_mse") : 0.0;
  x.d.null_path_mse = j.contains("null_path_mse") ? Num(j, "null_path_mse") : 0.0;
  x.d.null_path_sd = j.contains("null_path_sd") ? Num(j, "null_path_sd") : 0.0;
  // States written before the per-replicate scores have only their mean and sd: the
  // verdict's tests cannot be redone on them.
  if (j.contains("null_base_cv_mses")) x.d.null_base_cv_mses = Nums(j, "null_base_cv_mses");
  if (j.contains("null_path_mses")) x.d.null_path_mses = Nums(j, "null_path_mses");
  if (x.ok && x.d.null_base_cv_mses.empty())
    throw std::runtime_error("no per-replicate noise-only scores (a state written before decision 0039)");
  auto fit = [](const nlohmann::json& e) {
    EffectFit f;
    f.name = e.at("name");
    f.param_names = e.at("param_names").get<std::vector<std::string>>();
    f.extra_params = e.at("extra_params");
    f.testable = e.at("testable");
    f.params = Nums(e, "params");
    f.param_lo = Nums(e, "param_lo");
    f.param_hi = Nums(e, "param_hi");
    f.null_param_sd = Nums(e, "null_param_sd");
    f.cv_mse = Num(e, "cv_mse");
    f.cv_e_mm = Num(e, "cv_e_mm");
    f.block_sum = Nums(e, "block_sum");
    f.block_count = Nums(e, "block_count");
    f.null_improvements = Nums(e, "null_improvements");
    f.refined = e.at("refined");
    f.own_cv_mse = Num(e, "own_cv_mse");
    f.own_cv_e_mm = Num(e, "own_cv_e_mm");
    f.own_block_sum = Nums(e, "own_block_sum");
    f.simex_mse = Nums(e, "simex_mse");
    f.simex_own_mse = Nums(e, "simex_own_mse");
    f.estimated = e.at("estimated");
    return f;
  };
  x.d.simex_base_mse = Nums(j, "simex_base_mse");
  x.d.base_cv = fit(j.at("base_cv"));
  for (const auto& e : j.at("effects")) x.d.effects.push_back(fit(e));
  x.d.gap_signature = GapSignatureOf(j.at("gap_signature"));
  // States written before the replicates' marks were kept have none: the mark then holds
  // nothing back (ShowsGapSignature).
  if (j.contains("null_gap_z")) x.d.null_gap_z = Nums(j, "null_gap_z");
  return true;
}

wormdrag::Json SummaryJson(const Outcome& x) {
  wormdrag::Json params = wormdrag::Json::array();
  for (const auto& f : x.d.effects)
    if (f.name == x.d.verdict)
      for (size_t k = 0; k < f.params.size(); ++k)
        params.push_back({{"name", f.param_names[k]},
                          {"value", NumberOrNull(f.params[k])},
                          {"lo", NumberOrNull(f.param_lo[k])},
                          {"hi", NumberOrNull(f.param_hi[k])}});
  return {{"category", x.c.category},
          {"effect", x.c.effect},
          {"strength", x.c.strength},
          {"truth", x.c.truth.ToString()},
          {"source", SourceName(x.c)},
          {"family", FamilyName(x.c.family)},
          {"regime", x.c.regime},
          {"fps", NumberOrNull(x.c.fps)},
          {"duration", NumberOrNull(x.c.duration)},
          {"noise", NumberOrNull(x.c.noise)},
          {"coef", x.c.coef.ToString()},
          {"ok", x.ok},
          {"verdict", x.d.verdict},
          {"set", x.d.verdict_set},
          {"params", params},
          {"e_before", NumberOrNull(x.d.e_before)},
          {"e_after", NumberOrNull(x.d.e_after)},
          {"e_true", NumberOrNull(x.e_true)},
          {"mse_true", NumberOrNull(x.mse_true)},
          {"base_cv_mse", NumberOrNull(x.d.base_cv.cv_mse)},
          {"floor", NumberOrNull(x.d.null_base_cv_e)},
          {"seconds", NumberOrNull(x.seconds)},
          {"error", x.error}};
}

}  // namespace wormdrag::diagnose_bench
