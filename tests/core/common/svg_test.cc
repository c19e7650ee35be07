#include "core/common/svg.h"
#include "core/common/format.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

size_t Count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t pos = 0; (pos = s.find(what, pos)) != std::string::npos; ++pos) ++n;
  return n;
}

TEST(Svg, PlotsAreSelfContainedAndBreakAtNaN) {
  svg::PlotSpec p;
  p.title = "a < b";
  svg::Series s;
  s.x = {0, 1, NAN, 3, 4};
  s.y = {0, 1, 2, 3, 5};
  s.label = "x&y";
  p.series.push_back(s);
  const std::string out = svg::RenderPlot(p);
  EXPECT_EQ(out.rfind("<svg", 0), 0u);
  EXPECT_NE(out.find("a &lt; b"), std::string::npos);
  EXPECT_NE(out.find("x&amp;y"), std::string::npos);
  size_t lines = 0;
  for (size_t pos = 0; (pos = out.find("<polyline", pos)) != std::string::npos; ++pos) ++lines;
  EXPECT_EQ(lines, 2u);
  svg::HeatmapSpec h;
  h.xs = {0, 1};
  h.ys = {0, 1, 2};
  h.z = {1, 2, NAN, 4, 5, 6};
  const std::string hm = svg::RenderHeatmap(h);
  EXPECT_NE(hm.find("#cccccc"), std::string::npos);  // the missing cell
  EXPECT_EQ(svg::Fmt(1e-5), "1e-5");
}

TEST(Svg, BarsScaleFromZeroAndMarkEachBar) {
  svg::BarSpec b;
  b.title = "by part";
  b.units = "mm";
  b.width = 460;
  b.height = 220;
  b.bars = {{"head", 2.0, "#c0392b", {{1.0, "#2980b9", "", "noise"}, {1.5, "#2980b9", "3,2", ""}}, "", ""},
            {"tail", 1.0, "#7f8c8d", {}, "", ""},
            {"gap & <x>", NAN, "", {}, "no runs", ""}};
  const std::string v = svg::RenderBars(b);
  EXPECT_EQ(v.rfind("<svg", 0), 0u);
  EXPECT_EQ(Count(v, "<rect x="), 2u);  // no bar for the NaN value
  EXPECT_EQ(Count(v, "stroke-width=\"2\""), 2u);
  EXPECT_NE(v.find("stroke-dasharray=\"3,2\""), std::string::npos);
  EXPECT_NE(v.find("gap &amp; &lt;x&gt;"), std::string::npos);
  EXPECT_NE(v.find("<title>noise</title>"), std::string::npos);
  // Vertical: the plot spans y 26 … 140 (title above, 80 px of labels below); the larger
  // bar reaches the top, the smaller half of it, both from the zero line.
  EXPECT_NE(v.find("y=\"26.0\" width=\"91.0\" height=\"114.0\""), std::string::npos) << v;
  EXPECT_NE(v.find("y=\"83.0\" width=\"91.0\" height=\"57.0\""), std::string::npos) << v;
  b.horizontal = true;
  const std::string h = svg::RenderBars(b);
  EXPECT_NE(h.find("no runs"), std::string::npos);  // the note stands where the bar would be
  // Horizontal: 150 px of labels, 60 at the right; a bar of 2 is 250 px, one of 1 half of it.
  EXPECT_NE(h.find("<rect x=\"150.0\""), std::string::npos) << h;
  EXPECT_NE(h.find("width=\"250.0\""), std::string::npos) << h;
  EXPECT_NE(h.find("width=\"125.0\""), std::string::npos) << h;
}

}  // namespace
}  // namespace wormdrag
