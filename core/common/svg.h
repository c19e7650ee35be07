// Inline SVG figures for self-contained HTML reports: line plots (with equal-aspect
// maps for paths), heat maps and bar charts. No scripts, no external fonts or resources.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace wormdrag::svg {

struct Series {
  std::vector<double> x, y;  // NaN breaks the line
  std::string color = "#1f77b4";
  double width = 1.5;
  std::string dash;      // e.g. "5,3"; empty = solid
  std::string label;     // legend entry; empty = none
  bool markers = false;  // small circles at the points
};

struct Axis {
  std::string label;
  bool log = false;
  std::optional<double> lo, hi;  // default: from the data
};

struct PlotSpec {
  std::string title;
  double width = 560, height = 360;
  Axis x, y;
  bool equal_aspect = false;  // one unit is as long on x as on y (maps of paths)
  std::vector<Series> series;
  std::vector<double> hlines;                     // dotted reference lines
  std::optional<std::pair<double, double>> mark;  // a star at (x, y)
};
std::string RenderPlot(const PlotSpec& p);

struct HeatmapSpec {
  std::string title;
  double width = 280, height = 250;
  std::vector<double> xs, ys;  // cell centres (ascending)
  std::vector<double> z;       // z[ix * ys.size() + iy]; NaN = no value (hatched grey)
  std::string xlabel, ylabel, zlabel;
  bool log_color = true;                          // colour by log10(z)
  std::optional<std::pair<double, double>> mark;  // the optimum
  std::optional<double> zlo, zhi;                 // colour range (default: from the data)
};
std::string RenderHeatmap(const HeatmapSpec& h);

// A bar chart: one bar per item from zero, each with short marks across it (a
// reference such as a null distribution's mean and upper bound, or a threshold).
struct BarMark {
  double value = 0;
  std::string color = "#2980b9";
  std::string dash;   // empty = solid
  std::string label;  // tooltip
};
struct Bar {
  std::string label;
  double value = 0;  // NaN: no bar; `note` is written in its place
  std::string color = "#1f77b4";
  std::vector<BarMark> marks;
  std::string note;
  std::string tooltip;  // default: label and value
};
struct BarSpec {
  std::string title;
  std::string units;  // of the values, written at the axis
  double width = 640, height = 220;
  bool horizontal = false;  // bars grow to the right from labels on the left
  std::vector<Bar> bars;
};
std::string RenderBars(const BarSpec& b);

// A horizontal colour bar for a heat map's range.
std::string RenderColorBar(double lo, double hi, bool log, const std::string& label, double width = 280);

// The opening tag of a figure of width × height px on a white background (sans-serif
// text); the figure ends with "</svg>".
std::string OpenFigure(double width, double height);
// A text element at (x, y) px, anchored "start", "middle" or "end"; `extra` adds
// attributes (e.g. " font-weight=\"bold\"").
std::string Text(double x, double y, const std::string& s, const std::string& anchor = "middle", int size = 11,
                 const std::string& extra = "");

// Colours: a perceptually ordered map (viridis-like) at u ∈ [0, 1], and a palette.
std::string ColorMap(double u);
const std::string& Palette(int i);

std::string Fmt(double v, int significant = 3);  // compact number

}  // namespace wormdrag::svg
