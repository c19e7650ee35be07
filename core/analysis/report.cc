#include "core/analysis/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <nlohmann/json.hpp>

#include "core/common/format.h"
#include "core/common/svg.h"
#include "core/diagnose/diagnosis.h"

namespace wormdrag {
namespace {

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

std::string PathFigures(const ReportData& d) {
  const auto& pair = *d.job.pair;
  const auto& pts = pair.options().points;
  std::string s;
  for (int j = 0; j < 2; ++j) {
    svg::PlotSpec p;
    p.title = "worm " + std::to_string(j + 1) + ": " + pair.worm(j).name;
    p.width = 580;
    p.height = 430;
    p.x.label = "x (mm)";
    p.y.label = "y (mm)";
    p.equal_aspect = true;
    for (size_t i = 0; i < pts.size(); ++i) {
      svg::Series m, sim;
      m.color = sim.color = svg::Palette(static_cast<int>(i));
      m.label = "joint " + std::to_string(pts[i]) + " measured";
      sim.label = "joint " + std::to_string(pts[i]) + " simulated";
      sim.dash = "5,3";
      sim.width = 1.3;
      const auto& tt = d.paths.t[j];
      for (size_t f = 0; f < d.paths.measured[j].size(); ++f) {
        // A break in time (missing frames) breaks the line.
        if (f > 0 && tt[f] - tt[f - 1] > 1.5 / pair.worm(j).kinematics.fps) {
          for (auto* ser : {&m, &sim}) {
            ser->x.push_back(NAN);
            ser->y.push_back(NAN);
          }
        }
        m.x.push_back(d.paths.measured[j][f][i].x());
        m.y.push_back(d.paths.measured[j][f][i].y());
        sim.x.push_back(d.paths.simulated[j][f][i].x());
        sim.y.push_back(d.paths.simulated[j][f][i].y());
      }
      p.series.push_back(std::move(m));
      p.series.push_back(std::move(sim));
    }
    s += "<div class=\"fig\">" + svg::RenderPlot(p) + "</div>";
  }
  // Distance over time.
  svg::PlotSpec e;
  e.title = "distance between measured and simulated points (mean over the evaluation points)";
  e.width = 1170;
  e.height = 260;
  e.x.label = "time (s)";
  e.y.label = "distance (% of body length)";
  e.y.lo = 0;
  for (int j = 0; j < 2; ++j) {
    svg::Series ser;
    ser.color = svg::Palette(j);
    ser.label = "worm " + std::to_string(j + 1);
    const double L = pair.worm(j).body_length();
    const auto& tt = d.paths.t[j];
    for (size_t f = 0; f < d.paths.measured[j].size(); ++f) {
      if (f > 0 && tt[f] - tt[f - 1] > 1.5 / pair.worm(j).kinematics.fps) {
        ser.x.push_back(NAN);
        ser.y.push_back(NAN);
      }
      double sum = 0;
      for (size_t i = 0; i < d.paths.measured[j][f].size(); ++i)
        sum += (d.paths.measured[j][f][i] - d.paths.simulated[j][f][i]).norm();
      ser.x.push_back(tt[f] - tt.front());
      ser.y.push_back(100 * sum / d.paths.measured[j][f].size() / L);
    }
    e.series.push_back(std::move(ser));
  }
  double top = 0;
  for (const auto& ser : e.series)
    for (double v : ser.y)
      if (std::isfinite(v)) top = std::max(top, v);
  e.hlines = {d.job.e_percent};
  if (top > 0.5) e.hlines.push_back(2.0);  // the paper's crawling figure, where it does not flatten the curves
  s += "<div class=\"fig\">" + svg::RenderPlot(e) + "</div>";
  s += "<p class=\"note\">Dotted lines: this fit's E (" + Fmt(d.job.e_percent, 3) + " % BL)" +
       (e.hlines.size() > 1 ? " and the paper's crawling figure (2 % BL)" : "") +
       ". Solid: measured; dashed: the body model driven by the measured "
       "joint angles with the estimated friction. Lines break where frames are missing (not scored)." +
       (pair.options().restart_after_gaps
            ? " This job restarts the simulated pose from the measured one after every gap, so each stretch between "
              "gaps is a separate, shorter prediction."
            : "") +
       "</p>";
  return s;
}

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
           "determine no friction ratio here, and none is shown.</p>";
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

std::string ScaleProfile(const ReportData& d, const nlohmann::json& id) {
  if (!id.contains("scale_profile") || id["scale_profile"].empty())
    return "<p class=\"note\">No scale profile stored.</p>";
  svg::PlotSpec p;
  p.title = "E along the scale ray: all four coefficients × factor";
  p.width = 580;
  p.height = 330;
  p.x.label = "scale factor";
  p.x.log = true;
  p.y.label = "E (% of body length)";
  svg::Series s;
  s.markers = true;
  const double L = d.job.pair->mean_body_length();
  double lo = 1e300, hi = -1e300;
  for (const auto& pt : id["scale_profile"]) {
    s.x.push_back(pt[0].get<double>());
    s.y.push_back(100 * pt[1].get<double>() / L);
    lo = std::min(lo, s.y.back());
    hi = std::max(hi, s.y.back());
  }
  p.series.push_back(s);
  p.mark = std::make_pair(1.0, d.job.e_percent);
  std::string out = "<div class=\"fig\">" + svg::RenderPlot(p) + "</div>";
  out += "<p class=\"note\">Over a " + Fmt(s.x.back() / s.x.front(), 2) +
         "-fold change of the overall scale E changes by " + Fmt(hi - lo, 2) + " % BL (" +
         Fmt((hi - lo) / 100 * L * 1000, 2) +
         " µm). Without inertia the path does not depend on the scale at all, so the absolute size of the "
         "coefficients and of every force below rests on the link mass alone; the ratios K<sub>μ</sub>, "
         "K<sub>η</sub> and the crossover speed v<sub>c</sub> are what the video determines.</p>";
  return out;
}

std::string Slices(const ReportData& d) {
  if (!d.slices) return "<p class=\"note\">" + HtmlEscape(d.slices_note) + "</p>";
  const GridSlices& g = *d.slices;
  const double L = d.job.pair->mean_body_length();
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (const auto& s : g.slices)
    for (double v : s.e)
      if (std::isfinite(v) && v > 0) {
        lo = std::min(lo, 100 * v / L);
        hi = std::max(hi, 100 * v / L);
      }
  std::string out;
  const auto oa = g.optimum.AsArray();
  for (const auto& s : g.slices) {
    svg::HeatmapSpec h;
    h.xs = s.va;
    h.ys = s.vb;
    for (double v : s.e) h.z.push_back(100 * v / L);
    h.xlabel = CoefficientSymbol(s.a);
    h.ylabel = CoefficientSymbol(s.b);
    h.zlabel = "E % BL";
    h.zlo = lo;
    h.zhi = hi;
    int o1 = 0, o2 = 0;
    for (int c = 0; c < 4; ++c)
      if (c != s.a && c != s.b) (o1 ? o2 : o1) = c + 1;
    h.title = std::string(CoefficientSymbol(o1 - 1)) + "=" + Fmt(oa[o1 - 1]) + ", " + CoefficientSymbol(o2 - 1) + "=" +
              Fmt(oa[o2 - 1]);
    h.mark = std::make_pair(oa[s.a], oa[s.b]);
    out += "<div class=\"fig\">" + svg::RenderHeatmap(h) + "</div>";
  }
  out += "<div>" + svg::RenderColorBar(lo, hi, true, "E (% of body length, log colour scale)", 420) + "</div>";
  out += "<p class=\"note\">Phase 1 grid (μ in steps of " + Fmt(g.search.d_mu) + " µN, η in steps of " +
         Fmt(g.search.d_eta) +
         " µN·s/mm), each panel a slice through the best grid point (red square, E = " + Fmt(100 * g.e_opt / L, 3) +
         " % BL at μn=" + Fmt(oa[0]) + ", μt=" + Fmt(oa[1]) + ", ηn=" + Fmt(oa[2]) + ", ηt=" + Fmt(oa[3]) +
         ") with the other two coefficients held there. " + std::to_string(g.evaluated) + " of " +
         std::to_string(g.total) +
         " grid points have a stored value (grey: none, because the set was abandoned early as worse than "
         "the Phase 1 survivors, which --full-grid avoids, or cannot be simulated). Long valleys through "
         "the optimum along a diagonal are the unidentified scale.</p>";
  return out;
}

std::string Forces(const ReportData& d) {
  if (!d.forces[0] && !d.forces[1]) return "<p class=\"note\">" + HtmlEscape(d.forces_note) + "</p>";
  std::string out;
  svg::PlotSpec p;
  p.title = "friction force on the body over time (at the estimate)";
  p.width = 1170;
  p.height = 300;
  p.x.label = "time (s)";
  p.y.label = "force (µN)";
  p.y.lo = 0;
  std::string table =
      "<table><tr><th class=\"l\">worm</th><th>RMS link force µN</th><th>mean Σ|f<sub>k</sub>| µN</th>"
      "<th>mean thrust µN</th><th>RMS net force µN</th><th>mean power dissipated nW</th></tr>";
  for (int j = 0; j < 2; ++j) {
    if (!d.forces[j]) continue;
    const auto& f = *d.forces[j];
    svg::Series a, b, c;
    a.color = b.color = c.color = svg::Palette(j);
    a.label = "worm " + std::to_string(j + 1) + ": Σ|f_k|";
    b.label = "worm " + std::to_string(j + 1) + ": thrust";
    b.dash = "5,3";
    c.label = "worm " + std::to_string(j + 1) + ": |net|";
    c.dash = "1,3";
    for (size_t i = 0; i < f.t.size(); ++i) {
      const double t = f.t[i] - f.t.front();
      a.x.push_back(t);
      a.y.push_back(f.magnitude_sum[i]);
      b.x.push_back(t);
      b.y.push_back(f.thrust[i]);
      c.x.push_back(t);
      c.y.push_back(f.net[i].norm());
    }
    p.series.push_back(a);
    p.series.push_back(b);
    p.series.push_back(c);
    table += "<tr><td class=\"l\">" + std::to_string(j + 1) + "</td><td>" + Fmt(f.rms_link, 3) + "</td><td>" +
             Fmt(f.mean_magnitude_sum, 3) + "</td><td>" + Fmt(f.mean_thrust, 3) + "</td><td>" + Fmt(f.rms_net, 3) +
             "</td><td>" + Fmt(f.mean_power, 3) + "</td></tr>";
  }
  out += "<div class=\"fig\">" + svg::RenderPlot(p) + "</div>";
  out += table + "</table>";
  // Kymograph of the normal force per link (worm 1).
  for (int j = 0; j < 2; ++j) {
    if (!d.forces[j]) continue;
    const auto& f = *d.forces[j];
    svg::HeatmapSpec h;
    h.title = "worm " + std::to_string(j + 1) + ": |friction force| per link";
    h.width = 580;
    h.height = 240;
    const size_t step = std::max<size_t>(1, f.t.size() / 150);
    for (size_t i = 0; i < f.t.size(); i += step) h.xs.push_back(f.t[i] - f.t.front());
    for (int k = 1; k <= kNumLinks; ++k) h.ys.push_back(k);
    for (size_t i = 0; i < f.t.size(); i += step)
      for (int k = 0; k < kNumLinks; ++k) h.z.push_back(f.force[i][k].norm());
    h.xlabel = "time (s)";
    h.ylabel = "link (1 = head)";
    h.zlabel = "µN";
    h.log_color = false;
    h.zlo = 0;
    out += "<div class=\"fig\">" + svg::RenderHeatmap(h) + "</div>";
  }
  out +=
      "<p class=\"note\">Per link k the friction force f<sub>k</sub> = f<sub>t</sub> t<sub>k</sub> + f<sub>n</sub> "
      "n<sub>k</sub> (docs/conventions.md §1) at every frame of the simulation with the estimate. Σ|f<sub>k</sub>|: "
      "total "
      "magnitude; thrust: the sum of the links' force components along the body's direction of travel (the "
      "propulsion); net: Σf<sub>k</sub>, the force summed over the body (the paper's Fig. 12a), which equals the "
      "rate of change of momentum and is ≈ 0 at these masses: propulsion and drag balance (except at the first frame "
      "of a "
      "simulated stretch, where the body, started at rest, is accelerated; the table leaves those frames out). "
      "<b>Scale:</b> all forces "
      "are proportional to the unidentified overall coefficient scale (docs/conventions.md §2); their time course and "
      "the "
      "distribution over the body are determined by the data, their absolute size in µN only through inertia. "
      "Compare forces between jobs only as ratios at a common scale assumption.</p>";
  return out;
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
        "gives); blue: noise-only refits (solid mean, dashed mean + 2 sd).</p>";
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
