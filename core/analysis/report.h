// `wormdrag report`: one self-contained HTML file (inline SVG and CSS, no scripts,
// no network, no external fonts) that a biologist can read: measured vs simulated
// paths of the evaluation points (paper Fig. 4, 8), the coefficients with what the
// data determine (docs/conventions.md §2), E along the scale ray, E over the Phase 1 grid as 2-D
// slices through the optimum, friction forces over time (Fig. 12) and the sim-to-real
// diagnosis when one is given.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "core/analysis/forces.h"
#include "core/analysis/job_analysis.h"
#include "core/common/status.h"
#include "core/store/job_store.h"

namespace wormdrag {

struct ReportData {
  LoadedJob job;
  PathComparison paths;  // at the estimate
  std::optional<GridSlices> slices;
  std::string slices_note;  // why there are none
  std::array<std::optional<LinkForceSeries>, 2> forces;
  std::string forces_note;
  std::string diagnosis_json;  // `wormdrag diagnose --json` output, may be empty
  std::string source_label;    // e.g. the database path, for the footer
};

// Everything the report shows for a finished job (NOT_FOUND / FAILED_PRECONDITION as
// LoadDoneJob). Figures that cannot be made (e.g. no Phase 1 values) carry a note.
Result<ReportData> CollectReport(JobStore& store, int64_t id);

std::string RenderReportHtml(const ReportData& d);

}  // namespace wormdrag
