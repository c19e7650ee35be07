// The saved state of a run: one JSON line per outcome with what Decide and the report
// need (--state), read back by --redecide; and the one-line summary of an outcome.
#include <cstdio>
#include <stdexcept>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {
namespace {

nlohmann::json GapSignatureJson(const GapSignature& g) {
  return {{"gaps", g.gaps},           {"windows", g.windows}, {"at_gaps", g.at_gaps},
          {"elsewhere", g.elsewhere}, {"excess", g.excess},   {"se", g.se}};
}
GapSignature GapSignatureOf(const nlohmann::json& j) {
  GapSignature g;
  g.gaps = j.at("gaps");
  g.windows = j.at("windows");
  g.at_gaps = j.at("at_gaps");
  g.elsewhere = j.at("elsewhere");
  g.excess = j.at("excess");
  g.se = j.at("se");
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
          {"gap_signature", GapSignatureJson(x.d.gap_signature)}};
}

bool OutcomeOf(const nlohmann::json& j, Outcome* out) {
  Outcome& x = *out;
  if (!CaseBySeed(j.at("seed").get<uint64_t>(), &x.c)) return false;
  x.ok = j.at("ok");
  x.error = j.at("error");
  x.e_true = j.at("e_true");
  x.mse_true = j.at("mse_true");
  x.mse_fitted_truth = j.at("mse_fitted_truth");
  x.e_fitted_truth = j.at("e_fitted_truth");
  x.seconds = j.at("seconds");
  x.d.noise_sigma = j.at("noise_sigma");
  x.d.null_base_cv_mse = j.at("null_base_cv_mse");
  x.d.null_base_cv_sd = j.at("null_base_cv_sd");
  x.d.null_base_cv_e = j.at("null_base_cv_e");
  // States written before the full-path gap test have no full path: the test is off there.
  x.d.path_mse = j.value("path_mse", 0.0);
  x.d.null_path_mse = j.value("null_path_mse", 0.0);
  x.d.null_path_sd = j.value("null_path_sd", 0.0);
  // States written before the per-replicate scores have only their mean and sd: the
  // verdict's tests cannot be redone on them.
  x.d.null_base_cv_mses = j.value("null_base_cv_mses", std::vector<double>{});
  x.d.null_path_mses = j.value("null_path_mses", std::vector<double>{});
  if (x.ok && x.d.null_base_cv_mses.empty())
    throw std::runtime_error("no per-replicate noise-only scores (a state written before decision 0039)");
  auto fit = [](const nlohmann::json& e) {
    EffectFit f;
    f.name = e.at("name");
    f.param_names = e.at("param_names").get<std::vector<std::string>>();
    f.extra_params = e.at("extra_params");
    f.testable = e.at("testable");
    f.params = e.at("params").get<std::vector<double>>();
    f.param_lo = e.at("param_lo").get<std::vector<double>>();
    f.param_hi = e.at("param_hi").get<std::vector<double>>();
    f.null_param_sd = e.at("null_param_sd").get<std::vector<double>>();
    f.cv_mse = e.at("cv_mse");
    f.cv_e_mm = e.at("cv_e_mm");
    f.block_sum = e.at("block_sum").get<std::vector<double>>();
    f.block_count = e.at("block_count").get<std::vector<double>>();
    f.null_improvements = e.at("null_improvements").get<std::vector<double>>();
    f.refined = e.at("refined");
    f.own_cv_mse = e.at("own_cv_mse");
    f.own_cv_e_mm = e.at("own_cv_e_mm");
    f.own_block_sum = e.at("own_block_sum").get<std::vector<double>>();
    f.simex_mse = e.at("simex_mse").get<std::vector<double>>();
    f.simex_own_mse = e.at("simex_own_mse").get<std::vector<double>>();
    f.estimated = e.at("estimated");
    return f;
  };
  x.d.simex_base_mse = j.at("simex_base_mse").get<std::vector<double>>();
  x.d.base_cv = fit(j.at("base_cv"));
  for (const auto& e : j.at("effects")) x.d.effects.push_back(fit(e));
  x.d.gap_signature = GapSignatureOf(j.at("gap_signature"));
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
