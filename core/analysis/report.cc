#include "core/analysis/report.h"

#include <cmath>
#include <limits>
#include <utility>

#include <nlohmann/json.hpp>

#include "core/analysis/internal/report_figures.h"
#include "core/common/format.h"
#include "core/common/svg.h"
#include "core/diagnose/diagnosis.h"

namespace wormdrag {
namespace {

using report_internal::Forces;
using report_internal::PathFigures;
using report_internal::ScaleProfile;
using report_internal::Slices;
using svg::Fmt;

double Num(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::numeric_limits<double>::quiet_NaN();
  return j[key].get<double>();
}

const char* kCss = R"(
body{font-family:sans-serif;margin:24px auto;max-width:1200px;color:#222;line-height:1.45;padding:0 16px}
h1{font-size:24px;margin-bottom:4px} h2{font-size:19px;border-bottom:1px solid #ccc;padding-bottom:3px;margin-top:30px}
.sub{color:#555} .fig{display:inline-block;vertical-align:top;margin:4px 8px 8px 0}
.key{display:flex;flex-wrap:wrap;gap:12px;margin:10px 0}
.box{border:1px solid #ccc;border-radius:6px;padding:8px 14px;background:#fafafa}
.big{font-size:22px;font-weight:bold} table{border-collapse:collapse;margin:8px 0}
td,th{border:1px solid #ccc;padding:4px 9px;text-align:right} th{background:#f0f0f0} td.l,th.l{text-align:left}
.note{color:#555;font-size:13px;max-width:980px} .warn{color:#8a4b00} code{background:#f3f3f3;padding:1px 4px}
)";

// The fit against a body that does not move, and the recordings' smoothing and noise.
std::string FitQuality(const nlohmann::json& r) {
  std::string s;
  if (r.contains("smoothing"))
    for (size_t w = 0; w < r["smoothing"].size(); ++w) {
      const auto& sm = r["smoothing"][w];
      s += "<p class=\"note\">Worm " + std::to_string(w + 1) + ": " + HtmlEscape(sm.value("method", std::string())) +
           "; estimated tracking noise " + Fmt(Num(sm, "noise_um"), 3) + " µm (" + Fmt(Num(sm, "noise_percent_bl"), 3) +
           " % BL).</p>";
    }
  if (r.contains("still_body")) {
    s += "<p class=\"note\">A body that keeps its measured shapes but does not move scores E = " +
         Fmt(Num(r["still_body"], "E_percent_BL"), 4) + " % BL; the fit's skill is " + Fmt(Num(r, "skill"), 3) +
         ".</p>";
    if (!r.value("explains_motion", true))
      s += "<p class=\"note warn\">The fit explains the motion no better than a body that does not move: the data "
           "determine no friction ratio here, and none is shown. <code>wormdrag analyze progress</code> shows which "
           "part of the body's travel it misses.</p>";
  }
  return s;
}

std::string IntervalCell(const nlohmann::json& b, const char* k) {
  if (!b.contains(k)) return "–";
  const auto& c = b[k];
  if (c.value("determined", false)) {
    const std::string corrected = c.contains("corrected") ? Fmt(Num(c, "corrected"), 4) + " " : "";
    return corrected + "[" + Fmt(Num(c, "lo"), 4) + ", " + Fmt(Num(c, "hi"), 4) + "] (bias-corrected)";
  }
  return "not determined: " + HtmlEscape(c.value("why", std::string()));
}

std::string CoefficientTable(const ReportData& d, const nlohmann::json& id) {
  const Coefficients& c = d.job.estimate;
  const nlohmann::json result = nlohmann::json::parse(d.job.job.result_json, nullptr, false);
  const nlohmann::json r = result.is_object() ? result : nlohmann::json::object();
  const nlohmann::json b = r.contains("bootstrap") ? r["bootstrap"] : nlohmann::json::object();
  std::string s = "<table><tr><th class=\"l\">coefficient</th><th>estimate</th><th class=\"l\">unit</th></tr>";
  const char* names[] = {"μ<sub>n</sub> (normal, Coulomb)", "μ<sub>t</sub> (tangential, Coulomb)",
                         "η<sub>n</sub> (normal, viscous)", "η<sub>t</sub> (tangential, viscous)"};
  const char* units[] = {"µN", "µN", "µN·s/mm", "µN·s/mm"};
  const auto a = c.AsArray();
  for (int i = 0; i < 4; ++i)
    s += "<tr><td class=\"l\">" + std::string(names[i]) + "</td><td>" + Fmt(a[i], 4) + "</td><td class=\"l\">" +
         units[i] + "</td></tr>";
  s += "</table>";
  const nlohmann::json tol = id.contains("tolerance") ? id["tolerance"] : nlohmann::json::object();
  auto tol_text = [&](const char* k) {
    const double t = Num(tol, k);
    if (!std::isfinite(t)) return std::string("none (flat)");
    return Fmt(100 * t, 2) + " %";
  };
  s += FitQuality(r);
  if (!r.value("explains_motion", true)) return s;
  auto value = [](double v) { return std::isnan(v) ? std::string("undefined") : Fmt(v, 4); };
  const std::string level = b.contains("level") ? Fmt(100 * Num(b, "level"), 2) + " % interval (bootstrap)"
                                                : std::string("interval (none: no bootstrap)");
  s += "<table><tr><th class=\"l\">what the data determine</th><th>value</th><th>" + level +
       "</th><th>sensitivity: change that raises E by 1 % (not an uncertainty)</th></tr>";
  s += "<tr><td class=\"l\">K<sub>μ</sub> = μ<sub>n</sub>/μ<sub>t</sub></td><td>" + value(c.K_mu()) + "</td><td>" +
       IntervalCell(b, "K_mu") + "</td><td>" + tol_text("K_mu") + "</td></tr>";
  s += "<tr><td class=\"l\">K<sub>η</sub> = η<sub>n</sub>/η<sub>t</sub></td><td>" + value(c.K_eta()) + "</td><td>" +
       IntervalCell(b, "K_eta") + "</td><td>" + tol_text("K_eta") + "</td></tr>";
  s += "<tr><td class=\"l\">v<sub>c</sub> = μ<sub>t</sub>/η<sub>t</sub> (crossover speed)</td><td>" + value(c.v_c()) +
       " mm/s</td><td>" + IntervalCell(b, "v_c") + "</td><td>" + tol_text("v_c") + "</td></tr>";
  if (c.mu_t == 0 && c.eta_t == 0 && c.eta_n > 0)
    s += "<tr><td class=\"l\">μ<sub>n</sub>/η<sub>n</sub> (normal crossover speed; the tangential pair is 0)</td><td>" +
         Fmt(c.mu_n / c.eta_n, 4) + " mm/s</td><td>–</td><td>–</td></tr>";
  s += "<tr><td class=\"l\">overall scale (all four × c)</td><td>–</td><td>" + IntervalCell(b, "scale") + "</td><td>" +
       tol_text("scale") + "</td></tr></table>";
  if (id.contains("summary")) s += "<p class=\"note\">" + HtmlEscape(id["summary"].get<std::string>()) + "</p>";
  if (id.contains("at_bound") && !id["at_bound"].empty()) {
    std::string b;
    for (const auto& v : id["at_bound"]) b += (b.empty() ? "" : ", ") + v.get<std::string>();
    s += "<p class=\"note warn\">Estimated as exactly 0 (at the bound): " + HtmlEscape(b) +
         ". A ratio with a zero denominator is infinite: the data say that friction component is negligible, "
         "not its size.</p>";
  }
  if (id.contains("eigenvalues") && !id["eigenvalues"].empty()) {
    std::string ev;
    for (const auto& v : id["eigenvalues"]) ev += (ev.empty() ? "" : ", ") + Fmt(v.get<double>(), 3);
    s += "<p class=\"note\">Hessian of E (mm) in log-coefficients, eigenvalues: " + ev +
         ". A near-zero eigenvalue is a direction the data cannot see (the scale ray when inertia is negligible).</p>";
  }
  return s;
}

std::string Diagnosis(const std::string& text) {
  if (text.empty())
    return "<p class=\"note\">No diagnosis given (run <code>wormdrag diagnose K1.csv K2.csv --json DIAG.json</code> "
           "and pass <code>--diagnosis DIAG.json</code>).</p>";
  auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return "<p class=\"note warn\">The diagnosis file is not a JSON object.</p>";
  std::string out;
  if (j.contains("verdict") && j["verdict"].is_string()) {
    const std::string confidence = j.contains("confidence") && j["confidence"].is_string()
                                       ? j["confidence"].get<std::string>()
                                       : "";
    out += "<div class=\"key\"><div class=\"box\">verdict<div class=\"big\">" +
           HtmlEscape(diagnose::VerdictLabel(j["verdict"].get<std::string>(), confidence)) + "</div></div></div>";
  }
  for (const char* k : {"explanation", "summary"})
    if (j.contains(k) && j[k].is_string()) out += "<p>" + HtmlEscape(j[k].get<std::string>()) + "</p>";
  if (j.contains("cautions") && j["cautions"].is_array())
    for (const auto& c : j["cautions"])
      if (c.is_string()) out += "<p class=\"note warn\">Caution: " + HtmlEscape(c.get<std::string>()) + "</p>";
  // Scalars.
  std::string rows;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.value().is_number() || it.value().is_boolean() ||
        (it.value().is_string() && it.key() != "verdict" && it.key() != "explanation" && it.key() != "summary" &&
         it.value().get<std::string>().size() < 80))
      rows += "<tr><td class=\"l\">" + HtmlEscape(it.key()) + "</td><td>" +
              HtmlEscape(it.value().is_number() ? Fmt(it.value().get<double>(), 4) : it.value().dump()) + "</td></tr>";
  if (!rows.empty()) out += "<table>" + rows + "</table>";
  // "Where" breakdowns: bars of value against the noise-only null.
  if (j.contains("where") && j["where"].is_array()) {
    for (const auto& b : j["where"]) {
      if (!b.is_object() || !b.contains("cells") || !b["cells"].is_array()) continue;
      diagnose::Breakdown breakdown{b.value("name", std::string("breakdown")), b.value("units", std::string()), {}};
      for (const auto& c : b["cells"])
        if (c.is_object())
          breakdown.cells.push_back(
              {c.value("label", std::string()), Num(c, "value"), Num(c, "noise_mean"), Num(c, "noise_hi")});
      out += "<div class=\"fig\">" + diagnose::BreakdownSvg(breakdown) + "</div>";
    }
    out +=
        "<p class=\"note\">Bars: the base fit's residual in each part (red: above what tracking noise alone "
        "gives); blue: noise-only refits (solid mean, dashed their prediction bound at the diagnosis's false-alarm "
        "rate).</p>";
  }
  const nlohmann::json effects = j.contains("which") && j["which"].is_object()
                                     ? j["which"].value("effects", nlohmann::json())
                                     : nlohmann::json();
  if (effects.is_array() && !effects.empty()) {
    out +=
        "<table><tr><th class=\"l\">effect</th><th>improvement</th><th>threshold</th><th>significant</th><th "
        "class=\"l\">note</th></tr>";
    for (const auto& e : effects) {
      if (!e.is_object()) continue;
      out += "<tr><td class=\"l\">" + HtmlEscape(e.value("name", std::string("?"))) + "</td><td>" +
             Fmt(Num(e, "improvement"), 3) + "</td><td>" + Fmt(Num(e, "threshold"), 3) + "</td><td>" +
             (e.contains("significant") ? HtmlEscape(e["significant"].dump()) : "–") + "</td><td class=\"l\">" +
             HtmlEscape(e.value("note", std::string())) + "</td></tr>";
    }
    out += "</table>";
  }
  return out;
}

}  // namespace

Result<ReportData> CollectReport(JobStore& store, int64_t id) {
  auto job = LoadDoneJob(store, id);
  if (!job.ok()) return job.status();
  ReportData d;
  d.job = std::move(*job);
  auto cmp = ComparePaths(*d.job.pair, d.job.estimate);
  if (!cmp.ok()) return cmp.status();
  d.paths = std::move(*cmp);
  auto slices = PhaseOneSlices(store, d.job.job, d.job.options.estimate.search);
  if (slices.ok())
    d.slices = std::move(*slices);
  else
    d.slices_note = "No E over the Phase 1 grid: " + slices.status().message();
  for (int j = 0; j < 2; ++j) {
    const auto& w = d.job.pair->worm(j);
    auto f = ComputeLinkForces(w.drive, d.job.estimate, d.job.pair->options().sim, &w.resets);
    if (f.ok())
      d.forces[j] = std::move(*f);
    else
      d.forces_note = "Forces not computed: " + f.status().message();
  }
  return d;
}

std::string RenderReportHtml(const ReportData& d) {
  const auto& pair = *d.job.pair;
  const auto& opt = d.job.options;
  auto result = nlohmann::json::parse(d.job.job.result_json, nullptr, false);
  const nlohmann::json id = (!result.is_discarded() && result.contains("identifiability")) ? result["identifiability"]
                                                                                           : nlohmann::json::object();
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
      "<meta name=\"viewport\" content=\"width=device-width\">"
      "<title>wormdrag report: job " +
      std::to_string(d.job.job.id) + "</title><style>" + kCss + "</style></head><body>\n";
  h += "<h1>Friction estimate, job " + std::to_string(d.job.job.id) + "</h1>";
  h += "<div class=\"sub\">" + HtmlEscape(pair.worm(0).name) + " + " + HtmlEscape(pair.worm(1).name) + " · created " +
       HtmlEscape(d.job.job.created_at) + " · wormdrag</div>";
  // Key numbers.
  const Coefficients& c = d.job.estimate;
  h += "<div class=\"key\">";
  h += "<div class=\"box\">path error E<div class=\"big\">" + Fmt(d.job.e_percent, 3) + " % BL</div>" +
       Fmt(d.job.e_mm * 1000, 3) + " µm; the paper: ≈2 % crawling, 4 % swimming</div>";
  h += "<div class=\"box\">K<sub>μ</sub> = μ<sub>n</sub>/μ<sub>t</sub><div class=\"big\">" + Fmt(c.K_mu(), 3) +
       "</div>normal vs tangential Coulomb</div>";
  h += "<div class=\"box\">K<sub>η</sub> = η<sub>n</sub>/η<sub>t</sub><div class=\"big\">" + Fmt(c.K_eta(), 3) +
       "</div>normal vs tangential viscous</div>";
  h += "<div class=\"box\">v<sub>c</sub> = μ<sub>t</sub>/η<sub>t</sub><div class=\"big\">" + Fmt(c.v_c(), 3) +
       " mm/s</div>Coulomb–viscous crossover</div>";
  h += "</div>";
  // Inputs.
  h += "<table><tr><th class=\"l\">worm</th><th class=\"l\">recording</th><th>frames scored</th><th>fps</th><th>body "
       "length mm</th><th>analysed s</th></tr>";
  for (int j = 0; j < 2; ++j) {
    const auto& w = pair.worm(j);
    h += "<tr><td class=\"l\">" + std::to_string(j + 1) + "</td><td class=\"l\">" + HtmlEscape(w.name) + "</td><td>" +
         std::to_string(w.frames.size()) + "</td><td>" + Fmt(w.kinematics.fps, 4) + "</td><td>" +
         Fmt(w.body_length(), 4) + "</td><td>" + Fmt(w.kinematics.Duration(), 3) + "</td></tr>";
  }
  h += "</table>";
  std::string pts;
  for (int p : pair.options().points) pts += (pts.empty() ? "" : ", ") + std::to_string(p);
  h += "<p class=\"note\">Evaluation points: joints " + pts + "; t<sub>max</sub> = " + Fmt(pair.options().t_max) +
       " s; shape smoothing: " +
       (opt.smoothing == SmoothingMethod::kAuto ? std::string("auto (smoothing spline, GCV per recording)")
        : opt.smoothing == SmoothingMethod::kLowpass
            ? Fmt(opt.lowpass_hz) + " Hz Butterworth" + std::string(opt.causal_filter ? " (causal)" : " (zero phase)")
            : std::string("none")) +
       "; solver " + SolverName(pair.options().sim.solver) + ", ε = " + Fmt(pair.options().sim.epsilon) + " mm/s" +
       (pair.options().restart_after_gaps ? "; the simulated pose restarts after each gap" : "") + ".</p>";

  h += "<h2>1. Measured and simulated paths</h2>" + PathFigures(d);
  h += "<h2>2. Coefficients and what the data determine</h2>" + CoefficientTable(d, id);
  h += "<h2>3. E along the scale ray</h2>" + ScaleProfile(d, id);
  h += "<h2>4. E over the Phase 1 grid: slices through the optimum</h2>" + Slices(d);
  h += "<h2>5. Friction forces (the paper's §4, Fig. 12)</h2>" + Forces(d);
  h += "<h2>6. Sim-to-real diagnosis</h2>" + Diagnosis(d.diagnosis_json);
  h += "<h2>Reproduce</h2><p class=\"note\"><code>wormdrag jobs show " + std::to_string(d.job.job.id) +
       (d.source_label.empty() ? "" : " --db " + HtmlEscape(d.source_label)) +
       "</code> prints the stored options; inputs by "
       "SHA-256: " +
       HtmlEscape(d.job.job.dataset_hashes[0].substr(0, 16)) + "…, " +
       HtmlEscape(d.job.job.dataset_hashes[1].substr(0, 16)) + "…. Units: mm, s, µN (docs/conventions.md §1).</p>";
  h += "</body></html>\n";
  return h;
}

}  // namespace wormdrag
