// The bar charts of svg.h.
#include "core/common/svg.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/common/format.h"

namespace wormdrag::svg {
namespace {

// A coordinate, to a tenth of a pixel.
std::string Num(double v) {
  return FormatFixed(v, 1);
}

std::string Tooltip(const Bar& b) {
  return "<title>" + HtmlEscape(b.tooltip.empty() ? b.label + ": " + Fmt(b.value, 4) : b.tooltip) + "</title>";
}

// A mark across a bar from (x1, y1) to (x2, y2).
std::string Mark(const BarMark& m, double x1, double y1, double x2, double y2) {
  return "<line x1=\"" + Num(x1) + "\" y1=\"" + Num(y1) + "\" x2=\"" + Num(x2) + "\" y2=\"" + Num(y2) + "\" stroke=\"" +
         m.color + "\" stroke-width=\"2\"" + (m.dash.empty() ? "" : " stroke-dasharray=\"" + m.dash + "\"") + ">" +
         (m.label.empty() ? "" : "<title>" + HtmlEscape(m.label) + "</title>") + "</line>";
}

}  // namespace

std::string RenderBars(const BarSpec& b) {
  // The value range: zero and every finite bar and mark.
  double lo = 0, hi = 0;
  for (const Bar& bar : b.bars) {
    if (std::isfinite(bar.value)) lo = std::min(lo, bar.value), hi = std::max(hi, bar.value);
    for (const BarMark& m : bar.marks)
      if (std::isfinite(m.value)) lo = std::min(lo, m.value), hi = std::max(hi, m.value);
  }
  if (!(hi > lo)) hi = lo + 1;
  const double W = b.width, H = b.height, title_h = b.title.empty() ? 0 : 18;
  const int n = std::max<int>(1, static_cast<int>(b.bars.size()));
  std::string s = OpenFigure(W, H) + "<g font-size=\"11\">";
  if (!b.title.empty()) s += Text(4, 13, b.title, "start", 11, " font-weight=\"bold\"");
  if (b.horizontal) {
    const double left = 150, right = 60, top = title_h + 4, bottom = 18;
    const double row = (H - top - bottom) / n;
    auto x = [&](double v) { return left + (W - left - right) * (v - lo) / (hi - lo); };
    s += "<line x1=\"" + Num(x(0)) + "\" y1=\"" + Num(top) + "\" x2=\"" + Num(x(0)) + "\" y2=\"" + Num(H - bottom) +
         "\" stroke=\"#333\"/>";
    for (size_t i = 0; i < b.bars.size(); ++i) {
      const Bar& bar = b.bars[i];
      const double y0 = top + row * static_cast<double>(i), yc = y0 + 0.65 * row;
      s += Text(left - 6, yc, bar.label, "end");
      if (!std::isfinite(bar.value)) {
        s += Text(x(0) + 4, yc, bar.note, "start", 11, " fill=\"#999\"");
        continue;
      }
      const double a = std::min(x(0), x(bar.value)), c = std::max(x(0), x(bar.value));
      s += "<rect x=\"" + Num(a) + "\" y=\"" + Num(y0 + 0.2 * row) + "\" width=\"" + Num(c - a) + "\" height=\"" +
           Num(0.6 * row) + "\" fill=\"" + bar.color + "\">" + Tooltip(bar) + "</rect>";
      for (const BarMark& m : bar.marks)
        if (std::isfinite(m.value)) s += Mark(m, x(m.value), y0 + 0.1 * row, x(m.value), y0 + 0.9 * row);
      s += Text(std::max(c, x(0)) + 4, yc, Fmt(bar.value, 3), "start", 11, " fill=\"#555\"");
    }
    s += Text(x(lo), H - 4, Fmt(lo, 3), "start") + Text(x(hi), H - 4, Fmt(hi, 3) + " " + b.units, "end");
  } else {
    const double left = 60, right = 10, top = title_h + 8, bottom = 80;
    const double bw = (W - left - right) / n;
    auto y = [&](double v) { return top + (H - top - bottom) * (hi - v) / (hi - lo); };
    s += "<line x1=\"" + Num(left) + "\" y1=\"" + Num(y(0)) + "\" x2=\"" + Num(W - right) + "\" y2=\"" + Num(y(0)) +
         "\" stroke=\"#333\"/>";
    s += Text(left - 4, y(hi) + 4, Fmt(hi, 3), "end") + Text(left - 4, y(0) + 4, "0 " + b.units, "end");
    for (size_t i = 0; i < b.bars.size(); ++i) {
      const Bar& bar = b.bars[i];
      const double x0 = left + bw * static_cast<double>(i);
      if (std::isfinite(bar.value)) {
        const double a = std::min(y(0), y(bar.value)), c = std::max(y(0), y(bar.value));
        s += "<rect x=\"" + Num(x0 + 0.15 * bw) + "\" y=\"" + Num(a) + "\" width=\"" + Num(0.7 * bw) + "\" height=\"" +
             Num(c - a) + "\" fill=\"" + bar.color + "\">" + Tooltip(bar) + "</rect>";
      }
      for (const BarMark& m : bar.marks)
        if (std::isfinite(m.value)) s += Mark(m, x0 + 0.1 * bw, y(m.value), x0 + 0.9 * bw, y(m.value));
      s += "<text transform=\"translate(" + Num(x0 + bw / 2) + "," + Num(y(0) + 10) + ") rotate(40)\">" +
           HtmlEscape(bar.label) + "</text>";
    }
  }
  return s + "</g></svg>";
}

}  // namespace wormdrag::svg
