// The report's figures: measured and simulated paths, E along the scale ray, E over
// the Phase 1 grid and the friction forces (report.cc lays out the page).
#include "core/analysis/internal/report_figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "core/common/format.h"
#include "core/common/svg.h"

namespace wormdrag::report_internal {

using svg::Fmt;

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

}  // namespace wormdrag::report_internal
