#include "core/common/svg.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/common/format.h"

namespace wormdrag::svg {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Scale {
  double lo = 0, hi = 1, a = 0, b = 1;  // data [lo, hi] → pixels [a, b]
  bool log = false;
  double operator()(double v) const {
    const double u = log ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo)) : (v - lo) / (hi - lo);
    return a + u * (b - a);
  }
};

double NiceStep(double range, int target) {
  const double raw = range / std::max(1, target);
  const double mag = std::pow(10, std::floor(std::log10(raw)));
  const double r = raw / mag;
  const double nice = r < 1.5 ? 1 : r < 3 ? 2 : r < 7 ? 5 : 10;
  return nice * mag;
}

std::vector<double> Ticks(double lo, double hi, bool log, int target) {
  std::vector<double> t;
  if (log) {
    for (int e = static_cast<int>(std::floor(std::log10(lo))); e <= static_cast<int>(std::ceil(std::log10(hi))); ++e)
      for (double m : {1.0, 2.0, 5.0}) {
        const double v = m * std::pow(10, e);
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) t.push_back(v);
      }
    if (t.size() > 8) {
      std::vector<double> d;
      for (double v : t)
        if (std::fabs(std::log10(v) - std::round(std::log10(v))) < 1e-9) d.push_back(v);
      t = d;
    }
    if (t.size() >= 2) return t;
    t.clear();  // a narrow log range: linear ticks read better
  }
  const double step = NiceStep(hi - lo, target);
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step)
    t.push_back(std::fabs(v) < 1e-12 * step ? 0 : v);
  return t;
}

void Range(const std::vector<Series>& s, bool x, bool log, double* lo, double* hi) {
  *lo = std::numeric_limits<double>::infinity();
  *hi = -*lo;
  for (const auto& ser : s)
    for (double v : x ? ser.x : ser.y)
      if (std::isfinite(v) && (!log || v > 0)) {
        *lo = std::min(*lo, v);
        *hi = std::max(*hi, v);
      }
  if (!std::isfinite(*lo)) {
    *lo = log ? 1 : 0;
    *hi = log ? 10 : 1;
  }
  if (*hi - *lo <= 1e-300 * std::max(1.0, std::fabs(*hi))) {
    const double pad = *lo != 0 ? std::fabs(*lo) * 0.1 : 1;
    if (log) {
      *lo /= 2;
      *hi *= 2;
    } else {
      *lo -= pad;
      *hi += pad;
    }
  } else if (!log) {
    const double pad = 0.04 * (*hi - *lo);
    *lo -= pad;
    *hi += pad;
  }
}

}  // namespace

std::string Fmt(double v, int significant) {
  if (!std::isfinite(v)) return std::isnan(v) ? "–" : (v > 0 ? "∞" : "−∞");
  std::string s = FormatNumber(v, significant);
  // 1e-05 → 1e-5
  auto e = s.find("e");
  if (e != std::string::npos) {
    std::string mant = s.substr(0, e), ex = s.substr(e + 1);
    const bool neg = ex[0] == '-';
    size_t k = (ex[0] == '-' || ex[0] == '+') ? 1 : 0;
    while (k + 1 < ex.size() && ex[k] == '0') ++k;
    s = mant + "e" + (neg ? "-" : "") + ex.substr(k);
  }
  return s;
}

std::string ColorMap(double u) {
  // viridis at 9 stops
  static const double kStops[9][3] = {{68, 1, 84},    {71, 44, 122}, {59, 81, 139},  {44, 113, 142}, {33, 144, 141},
                                      {39, 173, 129}, {92, 200, 99}, {170, 220, 50}, {253, 231, 37}};
  if (!std::isfinite(u)) return "#cccccc";
  u = std::clamp(u, 0.0, 1.0) * 8;
  const int i = std::min(7, static_cast<int>(u));
  const double f = u - i;
  char buf[8];
  int rgb[3];
  for (int c = 0; c < 3; ++c)
    rgb[c] = static_cast<int>(std::lround(kStops[i][c] + f * (kStops[i + 1][c] - kStops[i][c])));
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
  return buf;
}

const std::string& Palette(int i) {
  static const std::vector<std::string> kColors = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                   "#9467bd", "#8c564b", "#e377c2", "#17becf"};
  return kColors[static_cast<size_t>(i) % kColors.size()];
}

std::string Text(double x, double y, const std::string& s, const std::string& anchor, int size,
                 const std::string& extra) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"%s\" font-size=\"%d\"%s>", x, y,
                anchor.c_str(), size, extra.c_str());
  return buf + HtmlEscape(s) + "</text>";
}

std::string OpenFigure(double width, double height) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" "
                "font-family=\"sans-serif\"><rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>",
                width, height, width, height);
  return buf;
}

namespace {

constexpr double kPlotLeft = 62, kPlotRight = 14;  // margins of a plot's frame, px

// The legend's width of one series' entry, px (estimated from its label).
double LegendEntryWidth(const Series& ser) {
  return 40 + 6.0 * ser.label.size();
}

// The height of the legend below the plot: its entries wrap at the figure's width.
double LegendHeight(const PlotSpec& p) {
  double lx = kPlotLeft;
  int rows = 0;
  for (const auto& ser : p.series) {
    if (ser.label.empty()) continue;
    const double w = LegendEntryWidth(ser);
    if (rows == 0 || lx + w > p.width - kPlotRight) {
      ++rows;
      lx = kPlotLeft;
    }
    lx += w;
  }
  return rows * 15 + (rows ? 4 : 0);
}

// The frame of a plot: its pixel box and the data ranges its axes show.
struct PlotFrame {
  double ml, mt, pw, ph;
  Scale sx, sy;
};

PlotFrame FrameOf(const PlotSpec& p, double legend_height) {
  const double mt = p.title.empty() ? 12 : 28, mb = 44 + legend_height;
  double x0, x1, y0, y1;
  Range(p.series, true, p.x.log, &x0, &x1);
  Range(p.series, false, p.y.log, &y0, &y1);
  for (double h : p.hlines)
    if (std::isfinite(h)) {
      y0 = std::min(y0, h);
      y1 = std::max(y1, h);
    }
  if (p.x.lo) x0 = *p.x.lo;
  if (p.x.hi) x1 = *p.x.hi;
  if (p.y.lo) y0 = *p.y.lo;
  if (p.y.hi) y1 = *p.y.hi;
  const double pw = p.width - kPlotLeft - kPlotRight, ph = p.height - mt - mb;
  if (p.equal_aspect && !p.x.log && !p.y.log) {
    // Widen the narrower range so that a mm is as long on both axes.
    const double sx = (x1 - x0) / pw, sy = (y1 - y0) / ph;
    if (sx > sy) {
      const double c = 0.5 * (y0 + y1), h = 0.5 * sx * ph;
      y0 = c - h;
      y1 = c + h;
    } else {
      const double c = 0.5 * (x0 + x1), h = 0.5 * sy * pw;
      x0 = c - h;
      x1 = c + h;
    }
  }
  return {
      kPlotLeft, mt, pw, ph, Scale{x0, x1, kPlotLeft, kPlotLeft + pw, p.x.log}, Scale{y0, y1, mt + ph, mt, p.y.log}};
}

// Grid, ticks, frame, axis labels and the dashed horizontal lines.
std::string Axes(const PlotSpec& p, const PlotFrame& f) {
  const double ml = f.ml, mt = f.mt, pw = f.pw, ph = f.ph;
  std::string s;
  char buf[256];
  for (double t : Ticks(f.sx.lo, f.sx.hi, p.x.log, p.equal_aspect ? 5 : 6)) {
    const double X = f.sx(t);
    std::snprintf(buf, sizeof buf, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#e6e6e6\"/>", X, mt,
                  X, mt + ph);
    s += buf;
    s += Text(X, mt + ph + 14, Fmt(t, 4));
  }
  for (double t : Ticks(f.sy.lo, f.sy.hi, p.y.log, 5)) {
    const double Y = f.sy(t);
    std::snprintf(buf, sizeof buf, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#e6e6e6\"/>", ml, Y,
                  ml + pw, Y);
    s += buf;
    s += Text(ml - 5, Y + 4, Fmt(t, 4), "end");
  }
  std::snprintf(buf, sizeof buf,
                "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" stroke=\"#444\"/>", ml, mt,
                pw, ph);
  s += buf;
  s += Text(ml + pw / 2, mt + ph + 32, p.x.label);
  std::snprintf(buf, sizeof buf, " transform=\"rotate(-90 %.1f %.1f)\"", 14.0, mt + ph / 2);
  s += Text(14, mt + ph / 2, p.y.label, "middle", 11, buf);
  for (double h : p.hlines) {
    if (!std::isfinite(h)) continue;
    std::snprintf(buf, sizeof buf,
                  "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#888\" stroke-dasharray=\"2,3\"/>",
                  ml, f.sy(h), ml + pw, f.sy(h));
    s += buf;
  }
  return s;
}

// One series as polylines broken where a value is missing (or not positive on a log
// axis), with its markers.
std::string SeriesLines(const PlotSpec& p, const PlotFrame& f, const Series& ser) {
  std::string s, pts;
  char buf[256];
  auto flush = [&] {
    if (pts.empty()) return;
    std::snprintf(buf, sizeof buf, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"%.2g\"%s%s points=\"",
                  ser.color.c_str(), ser.width, ser.dash.empty() ? "" : " stroke-dasharray=\"",
                  ser.dash.empty() ? "" : (ser.dash + "\"").c_str());
    s += buf + pts + "\"/>";
    pts.clear();
  };
  for (size_t i = 0; i < ser.x.size() && i < ser.y.size(); ++i) {
    const bool ok = std::isfinite(ser.x[i]) && std::isfinite(ser.y[i]) && (!p.x.log || ser.x[i] > 0) &&
                    (!p.y.log || ser.y[i] > 0);
    if (!ok) {
      flush();
      continue;
    }
    std::snprintf(buf, sizeof buf, "%.1f,%.1f ", f.sx(ser.x[i]), f.sy(ser.y[i]));
    pts += buf;
    if (ser.markers) {
      std::snprintf(buf, sizeof buf, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2.5\" fill=\"%s\"/>", f.sx(ser.x[i]),
                    f.sy(ser.y[i]), ser.color.c_str());
      s += buf;
    }
  }
  flush();
  return s;
}

// The legend: one row below the axis label, wrapping.
std::string Legend(const PlotSpec& p, double legend_height) {
  std::string s;
  char buf[256];
  double lx = kPlotLeft, ly = p.height - legend_height + 12;
  for (const auto& ser : p.series) {
    if (ser.label.empty()) continue;
    const double w = LegendEntryWidth(ser);
    if (lx + w > p.width - kPlotRight) {
      lx = kPlotLeft;
      ly += 15;
    }
    std::snprintf(buf, sizeof buf,
                  "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"2\"%s%s/>", lx,
                  ly - 4, lx + 22, ly - 4, ser.color.c_str(), ser.dash.empty() ? "" : " stroke-dasharray=\"",
                  ser.dash.empty() ? "" : (ser.dash + "\"").c_str());
    s += buf;
    s += Text(lx + 26, ly, ser.label, "start", 10);
    lx += w;
  }
  return s;
}

}  // namespace

std::string RenderPlot(const PlotSpec& p) {
  const double legend_height = LegendHeight(p);
  const PlotFrame f = FrameOf(p, legend_height);
  std::string s = OpenFigure(p.width, p.height);
  if (!p.title.empty()) s += Text(p.width / 2, 17, p.title, "middle", 13, " font-weight=\"bold\"");
  s += Axes(p, f);
  // Data, clipped to the frame. Figures of one page need distinct clip ids; the
  // counter is atomic because a library function may be called from several threads.
  static std::atomic<int> clip_id{0};
  const int cid = ++clip_id;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "<clipPath id=\"c%d\"><rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\"/></clipPath><g "
                "clip-path=\"url(#c%d)\">",
                cid, f.ml, f.mt, f.pw, f.ph, cid);
  s += buf;
  for (const auto& ser : p.series) s += SeriesLines(p, f, ser);
  if (p.mark) {
    std::snprintf(buf, sizeof buf,
                  "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"5\" fill=\"none\" stroke=\"black\" stroke-width=\"2\"/>",
                  f.sx(p.mark->first), f.sy(p.mark->second));
    s += buf;
  }
  s += "</g>";
  s += Legend(p, legend_height);
  s += "</svg>";
  return s;
}

std::string RenderHeatmap(const HeatmapSpec& h) {
  const double ml = 52, mr = 10, mt = h.title.empty() ? 10 : 26, mb = 40;
  const size_t nx = h.xs.size(), ny = h.ys.size();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : h.z)
    if (std::isfinite(v) && (!h.log_color || v > 0)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (h.zlo) lo = *h.zlo;
  if (h.zhi) hi = *h.zhi;
  auto u = [&](double v) {
    if (!std::isfinite(v) || !(hi > lo)) return kNaN;
    if (h.log_color) return v > 0 ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo)) : kNaN;
    return (v - lo) / (hi - lo);
  };
  const double pw = h.width - ml - mr, ph = h.height - mt - mb;
  const double cw = pw / std::max<size_t>(1, nx), ch = ph / std::max<size_t>(1, ny);
  std::string s = OpenFigure(h.width, h.height);
  char buf[320];
  if (!h.title.empty()) s += Text(h.width / 2, 16, h.title, "middle", 12, " font-weight=\"bold\"");
  for (size_t ix = 0; ix < nx; ++ix)
    for (size_t iy = 0; iy < ny; ++iy) {
      const double v = h.z[ix * ny + iy];
      std::snprintf(buf, sizeof buf,
                    "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"%s\"><title>%s</title></rect>",
                    ml + ix * cw, mt + ph - (iy + 1) * ch, cw + 0.3, ch + 0.3, ColorMap(u(v)).c_str(),
                    HtmlEscape(h.xlabel + "=" + Fmt(h.xs[ix]) + ", " + h.ylabel + "=" + Fmt(h.ys[iy]) + ": " +
                               h.zlabel + " " + Fmt(v, 4))
                        .c_str());
      s += buf;
    }
  std::snprintf(buf, sizeof buf,
                "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" stroke=\"#444\"/>", ml, mt,
                pw, ph);
  s += buf;
  const size_t every_x = nx > 6 ? (nx + 4) / 5 : 1, every_y = ny > 6 ? (ny + 4) / 5 : 1;
  for (size_t ix = 0; ix < nx; ix += every_x)
    s += Text(ml + (ix + 0.5) * cw, mt + ph + 13, Fmt(h.xs[ix]), "middle", 10);
  for (size_t iy = 0; iy < ny; iy += every_y)
    s += Text(ml - 4, mt + ph - (iy + 0.5) * ch + 4, Fmt(h.ys[iy]), "end", 10);
  s += Text(ml + pw / 2, h.height - 8, h.xlabel);
  std::snprintf(buf, sizeof buf, " transform=\"rotate(-90 %.1f %.1f)\"", 12.0, mt + ph / 2);
  s += Text(12, mt + ph / 2, h.ylabel, "middle", 11, buf);
  if (h.mark && nx > 1 && ny > 1) {
    auto cell = [](const std::vector<double>& v, double x) {
      size_t best = 0;
      for (size_t i = 1; i < v.size(); ++i)
        if (std::fabs(v[i] - x) < std::fabs(v[best] - x)) best = i;
      return best;
    };
    const size_t ix = cell(h.xs, h.mark->first), iy = cell(h.ys, h.mark->second);
    std::snprintf(buf, sizeof buf,
                  "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"none\" stroke=\"#e8003a\" "
                  "stroke-width=\"2.5\"/>",
                  ml + ix * cw, mt + ph - (iy + 1) * ch, cw, ch);
    s += buf;
  }
  s += "</svg>";
  return s;
}

std::string RenderColorBar(double lo, double hi, bool log, const std::string& label, double width) {
  const double h = 46, ml = 20, mr = 20, bw = width - ml - mr;
  std::string s = OpenFigure(width, h);
  char buf[256];
  const int n = 40;
  for (int i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof buf, "<rect x=\"%.2f\" y=\"4\" width=\"%.2f\" height=\"12\" fill=\"%s\"/>",
                  ml + i * bw / n, bw / n + 0.3, ColorMap((i + 0.5) / n).c_str());
    s += buf;
  }
  auto pos = [&](double v) {
    const double u = log ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo)) : (v - lo) / (hi - lo);
    return ml + u * bw;
  };
  if (hi > lo && (!log || lo > 0))
    for (double t : Ticks(lo, hi, log, 5)) s += Text(pos(t), 28, Fmt(t, 3), "middle", 10);
  s += Text(width / 2, 42, label, "middle", 10);
  s += "</svg>";
  return s;
}

}  // namespace wormdrag::svg
