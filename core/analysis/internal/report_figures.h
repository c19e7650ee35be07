// The report's figure sections (report_figures.cc), each as an HTML fragment with
// inline SVG. Private to core/analysis: RenderReportHtml (report.h) lays them out.
#pragma once

#include <string>

#include <nlohmann/json_fwd.hpp>

#include "core/analysis/report.h"

namespace wormdrag::report_internal {

// Measured and simulated paths of the evaluation points, one figure per worm.
std::string PathFigures(const ReportData& d);
// E along the scale ray (identifiability.scale_profile of the stored result `id`).
std::string ScaleProfile(const ReportData& d, const nlohmann::json& id);
// E over the Phase 1 grid: 2-D slices through the optimum.
std::string Slices(const ReportData& d);
// Friction forces per link over time (the paper's Fig. 12).
std::string Forces(const ReportData& d);

}  // namespace wormdrag::report_internal
