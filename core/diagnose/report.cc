// JSON, text and self-contained HTML (inline SVG, no external resources) of a diagnosis.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/format.h"
#include "core/common/json.h"
#include "core/diagnose/diagnosis.h"

namespace wormdrag::diagnose {
namespace {

// A number in the SVG figures; a non-finite one prints as "null", as the JSON has it.
std::string Num(double v) {
  return std::isfinite(v) ? FormatNumber(v, 6) : "null";
}
std::string Esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<')
      o += "&lt;";
    else if (c == '>')
      o += "&gt;";
    else if (c == '&')
      o += "&amp;";
    else
      o += c;
  }
  return o;
}
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

// Grouped bar chart: data bars and null markers (mean, mean + 2 sd).
std::string BarSvg(const Breakdown& b) {
  const int W = 640, H = 220, left = 60, bottom = 60, top = 20;
  const int n = static_cast<int>(b.cells.size());
  double vmax = 1e-12;
  for (const auto& c : b.cells) vmax = std::max({vmax, c.value, c.null_hi});
  const double bw = double(W - left - 10) / std::max(1, n);
  std::string s = "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(W) + "' height='" +
                  std::to_string(H) + "' font-size='10'>";
  auto y = [&](double v) { return top + (H - top - bottom) * (1 - v / vmax); };
  s += "<line x1='" + std::to_string(left) + "' y1='" + Num(y(0)) + "' x2='" + std::to_string(W - 10) + "' y2='" +
       Num(y(0)) + "' stroke='#333'/>";
  s += "<text x='4' y='" + Num(top + 8) + "'>" + Num(vmax) + "</text><text x='4' y='" + Num(y(0)) + "'>0 " +
       Esc(b.units) + "</text>";
  for (int i = 0; i < n; ++i) {
    const auto& c = b.cells[i];
    const double x = left + i * bw;
    s += "<rect x='" + Num(x + bw * 0.15) + "' y='" + Num(y(c.value)) + "' width='" + Num(bw * 0.7) + "' height='" +
         Num(y(0) - y(c.value)) + "' fill='" + (c.above_noise() ? "#c0392b" : "#7f8c8d") + "'><title>" + Esc(c.label) +
         ": " + Num(c.value) + " (noise " + Num(c.null_mean) + ", hi " + Num(c.null_hi) + ")</title></rect>";
    s += "<line x1='" + Num(x + bw * 0.1) + "' x2='" + Num(x + bw * 0.9) + "' y1='" + Num(y(c.null_mean)) + "' y2='" +
         Num(y(c.null_mean)) + "' stroke='#2980b9' stroke-width='2'/>";
    s += "<line x1='" + Num(x + bw * 0.1) + "' x2='" + Num(x + bw * 0.9) + "' y1='" + Num(y(c.null_hi)) + "' y2='" +
         Num(y(c.null_hi)) + "' stroke='#2980b9' stroke-dasharray='3,2'/>";
    s += "<text transform='translate(" + Num(x + bw / 2) + "," + Num(y(0) + 8) + ") rotate(40)'>" + Esc(c.label) +
         "</text>";
  }
  return s + "</svg>";
}

std::string EffectSvg(const Diagnosis& d) {
  const int W = 640, H = 240, left = 130, top = 10;
  const int n = static_cast<int>(d.effects.size());
  double vmax = 0.05, vmin = 0;
  for (const auto& e : d.effects)
    if (e.testable) {
      vmax = std::max({vmax, e.improvement, e.threshold});
      vmin = std::min(vmin, e.improvement);
    }
  const double rh = double(H - top - 20) / std::max(1, n);
  auto x = [&](double v) { return left + (W - left - 20) * (v - vmin) / (vmax - vmin); };
  std::string s = "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(W) + "' height='" +
                  std::to_string(H) + "' font-size='11'>";
  s += "<line x1='" + Num(x(0)) + "' x2='" + Num(x(0)) + "' y1='" + std::to_string(top) + "' y2='" +
       std::to_string(H - 20) + "' stroke='#333'/>";
  for (int i = 0; i < n; ++i) {
    const auto& e = d.effects[i];
    const double y0 = top + i * rh;
    s += "<text x='4' y='" + Num(y0 + rh * 0.65) + "'>" + Esc(e.name) + "</text>";
    if (!e.testable) {
      s += "<text x='" + Num(x(0) + 4) + "' y='" + Num(y0 + rh * 0.65) + "' fill='#999'>" + Esc(e.note) + "</text>";
      continue;
    }
    const double a = std::min(x(0), x(e.improvement)), b = std::max(x(0), x(e.improvement));
    s += "<rect x='" + Num(a) + "' y='" + Num(y0 + rh * 0.2) + "' width='" + Num(b - a) + "' height='" + Num(rh * 0.6) +
         "' fill='" + (e.significant ? "#27ae60" : "#95a5a6") + "'><title>improvement " + Num(e.improvement) +
         "</title></rect>";
    s += "<line x1='" + Num(x(e.threshold)) + "' x2='" + Num(x(e.threshold)) + "' y1='" + Num(y0 + rh * 0.1) +
         "' y2='" + Num(y0 + rh * 0.9) + "' stroke='#c0392b' stroke-width='2'><title>threshold " + Num(e.threshold) +
         "</title></line>";
  }
  s += "<text x='" + Num(x(0)) + "' y='" + std::to_string(H - 5) + "'>0</text><text x='" + Num(x(vmax) - 30) + "' y='" +
       std::to_string(H - 5) + "'>" + Num(vmax) + "</text>";
  return s + "</svg>";
}

std::string ResidualSvg(const Diagnosis& d) {
  const int W = 640, H = 200, left = 50, top = 10, bottom = 30;
  double tmin = 1e300, tmax = -1e300, vmax = 1e-12;
  for (int j = 0; j < 2 && j < static_cast<int>(d.residual_t.size()); ++j)
    for (size_t i = 0; i < d.residual_t[j].size(); ++i) {
      tmin = std::min(tmin, d.residual_t[j][i]);
      tmax = std::max(tmax, d.residual_t[j][i]);
      vmax = std::max(vmax, d.residual_mm[j][i]);
    }
  if (!(tmax > tmin)) return "";
  std::string s = "<svg xmlns='http://www.w3.org/2000/svg' width='" + std::to_string(W) + "' height='" +
                  std::to_string(H) + "' font-size='10'>";
  const char* colour[2] = {"#2c3e50", "#e67e22"};
  for (int j = 0; j < 2 && j < static_cast<int>(d.residual_t.size()); ++j) {
    std::string pts;
    for (size_t i = 0; i < d.residual_t[j].size(); ++i)
      pts += Num(left + (W - left - 10) * (d.residual_t[j][i] - tmin) / (tmax - tmin)) + "," +
             Num(top + (H - top - bottom) * (1 - d.residual_mm[j][i] / vmax)) + " ";
    s += "<polyline fill='none' stroke='" + std::string(colour[j]) + "' points='" + pts + "'/>";
  }
  s += "<text x='2' y='" + std::to_string(top + 8) + "'>" + Num(vmax) + " mm</text><text x='" + std::to_string(left) +
       "' y='" + std::to_string(H - 8) + "'>" + Num(tmin) + " s</text><text x='" + std::to_string(W - 60) + "' y='" +
       std::to_string(H - 8) + "'>" + Num(tmax) + " s</text>";
  return s + "</svg>";
}

}  // namespace

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
                          {"z", NumberOrNull(gap_signature.Z())}};
  j["which"] = {{"base_cv_mse_mm2", NumberOrNull(base_cv.cv_mse)},
                {"base_cv_E_mm", NumberOrNull(base_cv.cv_e_mm)},
                {"noise_floor_cv_mse_mm2", NumberOrNull(null_base_cv_mse)},
                {"noise_floor_cv_sd", NumberOrNull(null_base_cv_sd)},
                {"noise_floor_cv_E_mm", NumberOrNull(null_base_cv_e)},
                {"gap_beyond_noise", gap_beyond_noise},
                {"effects", effects_json}};
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

std::string Diagnosis::ToText() const {
  std::string s = "verdict: " + VerdictLabel(verdict, confidence) + "\n" + explanation + "\n\n";
  char b[900];
  std::snprintf(b, sizeof b,
                "base fit (quasi-static): mu_n %.4g, mu_t %.4g, eta_n %.4g, eta_t %.4g; E = %.4g mm "
                "(%.3g %% BL)\nrefitted on blocked paths (the held-out fits' start): mu_n %.4g, mu_t %.4g, eta_n "
                "%.4g, eta_t %.4g\ntracking noise %.3g mm (%s); gait %.3g Hz\n",
                base.mu_n, base.mu_t, base.eta_n, base.eta_t, base_e_mm, 100 * base_e_mm / body_length, cv_base.mu_n,
                cv_base.mu_t, cv_base.eta_n, cv_base.eta_t, noise_sigma, noise_estimated ? "estimated" : "given",
                gait_hz);
  s += b;
  for (const auto& c : cautions) s += "caution: " + c + "\n";
  s += "\nwhere (data vs tracking noise alone; * = above noise):\n";
  for (const auto& w : where) {
    s += "  " + w.name + " (" + w.units + "):";
    for (const auto& c : w.cells) {
      std::snprintf(b, sizeof b, " %s %.3g%s/%.3g", c.label.c_str(), c.value, c.above_noise() ? "*" : "", c.null_mean);
      s += b;
    }
    s += "\n";
  }
  if (gap_signature.Measured()) {
    std::snprintf(b, sizeof b,
                  "  dropped frames (residual change / model displacement): %.3g across the %d runs, %.3g across %d "
                  "as long stretches elsewhere; excess %.3g +- %.2g (z %.1f; gap_offset's mark)\n",
                  gap_signature.at_gaps, gap_signature.gaps, gap_signature.elsewhere, gap_signature.windows,
                  gap_signature.excess, gap_signature.se, gap_signature.Z());
    s += b;
  }
  std::snprintf(
      b, sizeof b,
      "\nwhich (held-out on %d blocks per worm, penalised; improvement vs threshold from noise-only "
      "refits):\n  base: CV MSE %.4g mm^2, E %.4g mm; noise floor %.4g mm^2, E %.4g mm; gap beyond noise: %s\n",
      blocks, base_cv.cv_mse, base_cv.cv_e_mm, null_base_cv_mse, null_base_cv_e, gap_beyond_noise ? "yes" : "no");
  s += b;
  for (const auto& e : effects) {
    if (!e.testable) {
      s += "  " + e.name + ": " + e.note + "\n";
      continue;
    }
    const std::string ps = ParameterText(e);
    std::snprintf(b, sizeof b, "  %-18s improvement %+.3f (threshold %.3f)%s  %s", e.name.c_str(), e.improvement,
                  e.threshold,
                  e.significant      ? " SIGNIFICANT"
                  : e.threshold >= 1 ? " (bar above 1: not detectable on this pair)"
                                     : "",
                  ps.c_str());
    s += b;
    if (e.refined) {
      std::snprintf(b, sizeof b, "; own fit: held-out E %.4g mm%s", e.own_cv_e_mm,
                    e.scored_own ? " (scored by it)" : "");
      s += b;
    }
    if (!e.simex_mse.empty()) {
      std::snprintf(b, sizeof b, "; with noise added: gain %+.3f (extrapolated %+.3f)", e.simex_gain,
                    e.simex_corrected);
      s += b;
      if (std::isfinite(e.simex_residual)) {
        std::snprintf(b, sizeof b, ", model error left %.2f of the base's", e.simex_residual);
        s += b;
      }
    }
    if (!e.note.empty()) s += "; " + e.note;
    s += "\n";
  }
  std::snprintf(
      b, sizeof b,
      "\nhow far (held-out): E %.4g mm [%.4g, %.4g] (%.3g %% BL) -> %.4g mm [%.4g, %.4g] (%.3g %% BL); shrink "
      "%.3g mm [%.3g, %.3g], %.0f %% of the gap above the noise floor\n",
      e_before, e_before_lo, e_before_hi, 100 * e_before / body_length, e_after, e_after_lo, e_after_hi,
      100 * e_after / body_length, shrink_mm, shrink_lo, shrink_hi, 100 * share_of_gap);
  s += b;
  return s;
}

std::string Diagnosis::ToHtml() const {
  std::string h =
      "<!DOCTYPE html><html><head><meta charset='utf-8'><title>wormdrag diagnosis</title><style>"
      "body{font-family:sans-serif;max-width:760px;margin:2em auto}pre{background:#f4f4f4;padding:8px;"
      "white-space:pre-wrap}</style></head><body>";
  h += "<h1>Sim-to-real gap: " + Esc(VerdictLabel(verdict, confidence)) + "</h1><p>" + Esc(explanation) + "</p>";
  for (const auto& c : cautions) h += "<p><strong>Caution:</strong> " + Esc(c) + "</p>";
  h += "<p>Recordings: " + Esc(names[0]) + ", " + Esc(names[1]) + ".</p>";
  h += "<h2>Where</h2><p>Grey/red bars: the base fit's residual (red: above what tracking noise alone gives). Blue: "
       "noise-only refits (solid mean, dashed mean + 2 sd).</p>";
  h += "<h3>Residual over time (mean distance of the 14 points)</h3>" + ResidualSvg(*this);
  for (const auto& w : where) h += "<h3>by " + Esc(w.name) + "</h3>" + BarSvg(w);
  h += "<h2>Which</h2><p>Relative held-out improvement of each catalogue effect (green: significant) and the bar it "
       "must clear (red: from noise-only data).</p>" +
       EffectSvg(*this);
  h += "<h2>How far</h2><pre>" + Esc(ToText()) + "</pre>";
  h += "</body></html>\n";
  return h;
}

}  // namespace wormdrag::diagnose
