// JSON, text and self-contained HTML (inline SVG, no external resources) of a diagnosis.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/format.h"
#include "core/common/json.h"
#include "core/common/svg.h"
#include "core/diagnose/diagnosis.h"

namespace wormdrag::diagnose {
namespace {

Json CoefJson(const Coefficients& c) {
  return {{"mu_n", NumberOrNull(c.mu_n)},
          {"mu_t", NumberOrNull(c.mu_t)},
          {"eta_n", NumberOrNull(c.eta_n)},
          {"eta_t", NumberOrNull(c.eta_t)}};
}

// One catalogue effect of the "which" section.
Json EffectJson(const EffectFit& e) {
  Json j = {{"name", e.name}, {"testable", e.testable}};
  if (!e.note.empty()) j["note"] = e.note;
  if (!e.testable) return j;
  Json params = Json::object();
  for (size_t k = 0; k < e.params.size(); ++k) {
    // A diagnosis without noise-only replicates has no spread of the estimate.
    const double noise_sd = k < e.null_param_sd.size() ? e.null_param_sd[k] : std::numeric_limits<double>::quiet_NaN();
    params[e.param_names[k]] = {{"value", NumberOrNull(e.params[k])}, {"estimated", e.estimated},
                                {"lo", NumberOrNull(e.param_lo[k])},  {"hi", NumberOrNull(e.param_hi[k])},
                                {"noise_sd", NumberOrNull(noise_sd)}, {"detectable_above", NumberOrNull(3 * noise_sd)}};
  }
  j["params"] = params;
  j["coefficients"] = CoefJson(e.coef);
  j["cv_mse_mm2"] = NumberOrNull(e.cv_mse);
  j["cv_score"] = NumberOrNull(e.cv_score);
  j["cv_E_mm"] = NumberOrNull(e.cv_e_mm);
  j["improvement"] = NumberOrNull(e.improvement);
  j["null_improvement_mean"] = NumberOrNull(e.null_mean);
  j["null_improvement_sd"] = NumberOrNull(e.null_sd);
  j["shrink_lo_mm"] = NumberOrNull(e.shrink_lo);
  j["threshold"] = NumberOrNull(e.threshold);
  j["significant"] = e.significant;
  if (e.refined) {
    j["own_fit_cv_mse_mm2"] = NumberOrNull(e.own_cv_mse);
    j["own_fit_cv_E_mm"] = NumberOrNull(e.own_cv_e_mm);
    j["scored_by_own_fit"] = e.scored_own;
  }
  if (!e.simex_mse.empty())
    j["simex"] = {{"noisy_copies", e.simex_mse.size()},
                  {"own_fit_on_copies", !e.simex_own_mse.empty()},
                  {"gain_with_added_noise", NumberOrNull(e.simex_gain)},
                  {"extrapolated_gain", NumberOrNull(e.simex_corrected)},
                  {"model_error_left", NumberOrNull(e.simex_residual)}};
  return j;
}

// Each effect's held-out improvement (green: significant) and the bar it must clear.
std::string EffectSvg(const Diagnosis& d) {
  svg::BarSpec spec;
  spec.horizontal = true;
  spec.height = 40 + 24.0 * static_cast<double>(d.effects.size());
  for (const auto& e : d.effects) {
    if (!e.testable) {
      spec.bars.push_back({e.name, std::numeric_limits<double>::quiet_NaN(), "", {}, e.note, ""});
      continue;
    }
    spec.bars.push_back({e.name,
                         e.improvement,
                         e.significant ? "#27ae60" : "#95a5a6",
                         {{e.threshold, "#c0392b", "", "threshold " + svg::Fmt(e.threshold, 4)}},
                         "",
                         "improvement " + svg::Fmt(e.improvement, 4)});
  }
  return svg::RenderBars(spec);
}

std::string ResidualSvg(const Diagnosis& d) {
  svg::PlotSpec p;
  p.width = 640;
  p.height = 240;
  p.x.label = "time (s)";
  p.y.label = "mean distance (mm)";
  for (size_t j = 0; j < 2 && j < d.residual_t.size() && j < d.residual_mm.size(); ++j) {
    svg::Series s;
    s.x = d.residual_t[j];
    s.y = d.residual_mm[j];
    s.color = j == 0 ? "#2c3e50" : "#e67e22";
    s.label = d.names[j];
    p.series.push_back(std::move(s));
  }
  if (p.series.empty() || p.series[0].x.empty()) return "";
  return svg::RenderPlot(p);
}

}  // namespace

std::string BreakdownSvg(const Breakdown& b) {
  svg::BarSpec spec;
  spec.title = "by " + b.name;
  spec.units = b.units;
  spec.height = 240;
  for (const auto& c : b.cells)
    spec.bars.push_back({c.label,
                         c.value,
                         c.above_noise() ? "#c0392b" : "#7f8c8d",
                         {{c.null_mean, "#2980b9", "", "noise mean"}, {c.null_hi, "#2980b9", "3,2", "noise bound"}},
                         "",
                         c.label + ": " + svg::Fmt(c.value, 4) + " (noise " + svg::Fmt(c.null_mean, 4) + ", hi " +
                             svg::Fmt(c.null_hi, 4) + ")"});
  return svg::RenderBars(spec);
}

std::string ParameterText(const EffectFit& e) {
  std::string s;
  for (size_t k = 0; k < e.params.size() && k < e.param_names.size(); ++k) {
    char b[200];
    if (e.estimated && k < e.param_lo.size() && k < e.param_hi.size())
      std::snprintf(b, sizeof b, "%s%s = %.4g [%.4g, %.4g]", k ? ", " : "", e.param_names[k].c_str(), e.params[k],
                    e.param_lo[k], e.param_hi[k]);
    else
      std::snprintf(b, sizeof b, "%s%s = %.4g (not estimated: its fits stayed at a start)", k ? ", " : "",
                    e.param_names[k].c_str(), e.params[k]);
    s += b;
  }
  return s;
}

std::string VerdictLabel(const std::string& verdict, const std::string& confidence) {
  return confidence.empty() ? verdict : verdict + " (" + confidence + ")";
}

std::string Diagnosis::ToJson() const {
  Json where_json = Json::array();
  for (const auto& b : where) {
    Json cells = Json::array();
    for (const auto& x : b.cells)
      cells.push_back({{"label", x.label},
                       {"value", NumberOrNull(x.value)},
                       {"noise_mean", NumberOrNull(x.null_mean)},
                       {"noise_hi", NumberOrNull(x.null_hi)},
                       {"above_noise", x.above_noise()}});
    where_json.push_back({{"name", b.name}, {"units", b.units}, {"cells", cells}});
  }
  Json effects_json = Json::array();
  for (const auto& e : effects) effects_json.push_back(EffectJson(e));
  Json j = {{"names", Json::array({names[0], names[1]})},
            {"verdict", verdict},
            {"verdict_set", verdict_set},
            {"confidence", confidence},
            {"margin", NumberOrNull(margin)},
            {"closest", closest},
            {"explanation", explanation},
            {"cautions", cautions},
            {"span_s", NumberOrNull(span_s)},
            {"body_length_mm", NumberOrNull(body_length)},
            {"noise_sigma_mm", NumberOrNull(noise_sigma)},
            {"noise_estimated", noise_estimated},
            {"gait_hz", NumberOrNull(gait_hz)},
            {"base",
             {{"coefficients", CoefJson(base)},
              {"E_mm", NumberOrNull(base_e_mm)},
              {"E_percent_BL", NumberOrNull(100 * base_e_mm / body_length)},
              {"blocked_refit", CoefJson(cv_base)}}},
            {"where", where_json}};
  if (gap_signature.Measured())
    j["gap_signature"] = {{"runs", gap_signature.gaps},
                          {"at_runs", NumberOrNull(gap_signature.at_gaps)},
                          {"stretches", gap_signature.windows},
                          {"elsewhere", NumberOrNull(gap_signature.elsewhere)},
                          {"excess", NumberOrNull(gap_signature.excess)},
                          {"se", NumberOrNull(gap_signature.se)},
                          {"z", NumberOrNull(gap_signature.Z())},
                          {"noise_only_z", null_gap_z},
                          {"noise_only_interval", {NumberOrNull(gap_signature_lo), NumberOrNull(gap_signature_hi)}}};
  j["which"] = {
      {"base_cv_mse_mm2", NumberOrNull(base_cv.cv_mse)},
      {"base_cv_E_mm", NumberOrNull(base_cv.cv_e_mm)},
      {"noise_floor_cv_mse_mm2", NumberOrNull(null_base_cv_mse)},
      {"noise_floor_cv_sd", NumberOrNull(null_base_cv_sd)},
      {"noise_floor_cv_E_mm", NumberOrNull(null_base_cv_e)},
      {"noise_floor_cv_mse_each_mm2", null_base_cv_mses},
      {"noise_bound_cv_mse_mm2", NumberOrNull(noise_bound_cv_mse)},
      {"gap_beyond_noise", gap_beyond_noise},
      {"effects", effects_json},
      {"path_mse_mm2", NumberOrNull(path_mse)},
      {"noise_floor_path_mse_mm2", NumberOrNull(null_path_mse)},
      {"noise_floor_path_sd", NumberOrNull(null_path_sd)},
      {"noise_floor_path_mse_each_mm2", null_path_mses},
      {"noise_bound_path_mse_mm2", NumberOrNull(noise_bound_path_mse)},
      {"path_beyond_noise", path_beyond_noise},
      {"noise_floor_gait_excess", {NumberOrNull(null_gait_excess[0]), NumberOrNull(null_gait_excess[1])}},
      {"noise_floor_truth",
       {NullUsesGait(0) ? "periodic gait" : "prepared shapes", NullUsesGait(1) ? "periodic gait" : "prepared shapes"}}};
  auto interval = [](double lo, double hi) { return Json::array({NumberOrNull(lo), NumberOrNull(hi)}); };
  j["how_far"] = {{"E_before_mm", NumberOrNull(e_before)},
                  {"E_before_interval", interval(e_before_lo, e_before_hi)},
                  {"E_after_mm", NumberOrNull(e_after)},
                  {"E_after_interval", interval(e_after_lo, e_after_hi)},
                  {"E_before_percent_BL", NumberOrNull(100 * e_before / body_length)},
                  {"E_after_percent_BL", NumberOrNull(100 * e_after / body_length)},
                  {"shrink_mm", NumberOrNull(shrink_mm)},
                  {"shrink_interval", interval(shrink_lo, shrink_hi)},
                  {"share_of_gap_above_noise", NumberOrNull(share_of_gap)},
                  {"held_out", "blocks with pose restarts, two folds"},
                  {"blocks_per_worm", blocks}};
  j["seconds"] = NumberOrNull(seconds);
  return Dump(j);
}

namespace {

std::string BaseText(const Diagnosis& d) {
  char b[900];
  std::snprintf(b, sizeof b,
                "base fit (quasi-static): mu_n %.4g, mu_t %.4g, eta_n %.4g, eta_t %.4g; E = %.4g mm "
                "(%.3g %% BL)\nrefitted on blocked paths (the held-out fits' start): mu_n %.4g, mu_t %.4g, eta_n "
                "%.4g, eta_t %.4g\ntracking noise %.3g mm (%s); gait %.3g Hz\n",
                d.base.mu_n, d.base.mu_t, d.base.eta_n, d.base.eta_t, d.base_e_mm, 100 * d.base_e_mm / d.body_length,
                d.cv_base.mu_n, d.cv_base.mu_t, d.cv_base.eta_n, d.cv_base.eta_t, d.noise_sigma,
                d.noise_estimated ? "estimated" : "given", d.gait_hz);
  std::string s = b;
  for (const auto& c : d.cautions) s += "caution: " + c + "\n";
  return s;
}

std::string WhereText(const Diagnosis& d) {
  std::string s = "\nwhere (data vs tracking noise alone; * = above noise):\n";
  char b[900];
  for (const auto& w : d.where) {
    s += "  " + w.name + " (" + w.units + "):";
    for (const auto& c : w.cells) {
      std::snprintf(b, sizeof b, " %s %.3g%s/%.3g", c.label.c_str(), c.value, c.above_noise() ? "*" : "", c.null_mean);
      s += b;
    }
    s += "\n";
  }
  const GapSignature& g = d.gap_signature;
  if (g.Measured()) {
    std::snprintf(b, sizeof b,
                  "  dropped frames (residual change / model displacement): %.3g across the %d runs, %.3g across %d "
                  "as long stretches elsewhere; excess %.3g +- %.2g (z %.1f; gap_offset's mark; noise alone "
                  "reaches %.1f … %.1f)\n",
                  g.at_gaps, g.gaps, g.elsewhere, g.windows, g.excess, g.se, g.Z(), d.gap_signature_lo,
                  d.gap_signature_hi);
    s += b;
  }
  return s;
}

// One effect's line of the "which" table.
std::string EffectLine(const EffectFit& e) {
  if (!e.testable) return "  " + e.name + ": " + e.note + "\n";
  char b[900];
  std::snprintf(b, sizeof b, "  %-18s improvement %+.3f (threshold %.3f)%s  %s", e.name.c_str(), e.improvement,
                e.threshold,
                e.significant      ? " SIGNIFICANT"
                : e.threshold >= 1 ? " (bar above 1: not detectable on this pair)"
                                   : "",
                ParameterText(e).c_str());
  std::string s = b;
  if (e.refined) {
    std::snprintf(b, sizeof b, "; own fit: held-out E %.4g mm%s", e.own_cv_e_mm, e.scored_own ? " (scored by it)" : "");
    s += b;
  }
  if (!e.simex_mse.empty()) {
    std::snprintf(b, sizeof b, "; with noise added: gain %+.3f (extrapolated %+.3f)", e.simex_gain, e.simex_corrected);
    s += b;
    if (std::isfinite(e.simex_residual)) {
      std::snprintf(b, sizeof b, ", model error left %.2f of the base's", e.simex_residual);
      s += b;
    }
  }
  if (!e.note.empty()) s += "; " + e.note;
  return s + "\n";
}

std::string WhichText(const Diagnosis& d) {
  char b[900];
  std::snprintf(
      b, sizeof b,
      "\nwhich (held-out on %d blocks per worm, penalised; improvement vs threshold from noise-only "
      "refits):\n  base: CV MSE %.4g mm^2, E %.4g mm; noise floor %.4g mm^2 (bound %.4g), E %.4g mm; gap beyond "
      "noise: %s\n"
      "  base, full path: MSE %.4g mm^2; noise floor %.4g mm^2 (bound %.4g); beyond noise: %s\n",
      d.blocks, d.base_cv.cv_mse, d.base_cv.cv_e_mm, d.null_base_cv_mse, d.noise_bound_cv_mse, d.null_base_cv_e,
      d.gap_beyond_noise ? "yes" : "no", d.path_mse, d.null_path_mse, d.noise_bound_path_mse,
      d.path_beyond_noise ? "yes" : "no");
  std::string s = b;
  if (std::isfinite(d.null_gait_excess[0]) || std::isfinite(d.null_gait_excess[1])) {
    std::snprintf(b, sizeof b,
                  "  noise-only replicates simulate: worm 1 %s, worm 2 %s (variance about a periodic gait: %.3g, "
                  "%.3g x the noise's)\n",
                  d.NullUsesGait(0) ? "a periodic gait" : "its prepared shapes",
                  d.NullUsesGait(1) ? "a periodic gait" : "its prepared shapes", d.null_gait_excess[0],
                  d.null_gait_excess[1]);
    s += b;
  }
  for (const auto& e : d.effects) s += EffectLine(e);
  return s;
}

std::string HowFarText(const Diagnosis& d) {
  char b[900];
  std::snprintf(
      b, sizeof b,
      "\nhow far (held-out): E %.4g mm [%.4g, %.4g] (%.3g %% BL) -> %.4g mm [%.4g, %.4g] (%.3g %% BL); shrink "
      "%.3g mm [%.3g, %.3g], %.0f %% of the gap above the noise floor\n",
      d.e_before, d.e_before_lo, d.e_before_hi, 100 * d.e_before / d.body_length, d.e_after, d.e_after_lo, d.e_after_hi,
      100 * d.e_after / d.body_length, d.shrink_mm, d.shrink_lo, d.shrink_hi, 100 * d.share_of_gap);
  return b;
}

}  // namespace

std::string Diagnosis::ToText() const {
  return "verdict: " + VerdictLabel(verdict, confidence) + "\n" + explanation + "\n\n" + BaseText(*this) +
         WhereText(*this) + WhichText(*this) + HowFarText(*this);
}

std::string Diagnosis::ToHtml() const {
  std::string h =
      "<!DOCTYPE html><html><head><meta charset='utf-8'><title>wormdrag diagnosis</title><style>"
      "body{font-family:sans-serif;max-width:760px;margin:2em auto}pre{background:#f4f4f4;padding:8px;"
      "white-space:pre-wrap}</style></head><body>";
  h += "<h1>Sim-to-real gap: " + HtmlEscape(VerdictLabel(verdict, confidence)) + "</h1><p>" + HtmlEscape(explanation) +
       "</p>";
  for (const auto& c : cautions) h += "<p><strong>Caution:</strong> " + HtmlEscape(c) + "</p>";
  h += "<p>Recordings: " + HtmlEscape(names[0]) + ", " + HtmlEscape(names[1]) + ".</p>";
  h += "<h2>Where</h2><p>Grey/red bars: the base fit's residual (red: above what tracking noise alone gives). Blue: "
       "noise-only refits (solid mean, dashed the prediction bound at the false-alarm rate).</p>";
  h += "<h3>Residual over time (mean distance of the 14 points)</h3>" + ResidualSvg(*this);
  for (const auto& w : where) h += BreakdownSvg(w);
  h += "<h2>Which</h2><p>Relative held-out improvement of each catalogue effect (green: significant) and the bar it "
       "must clear (red: from noise-only data).</p>" +
       EffectSvg(*this);
  h += "<h2>How far</h2><pre>" + HtmlEscape(ToText()) + "</pre>";
  h += "</body></html>\n";
  return h;
}

}  // namespace wormdrag::diagnose
