// wormdrag report: a self-contained HTML report of a stored job.
#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/results_table.h"
#include "core/analysis/report.h"
#include "core/store/job_store.h"

namespace wormdrag::cli {

int RunReport(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"out", "FILE.html", "report file to write", ""},
      {"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"},
      {"diagnosis", "DIAG.json", "a diagnosis of the same pair (wormdrag diagnose --json) to include", ""},
  };
  const std::string usage = Usage(
      "wormdrag report", "ID --out report.html [--db FILE] [--diagnosis DIAG.json]",
      "Writes one self-contained HTML file (inline SVG, no scripts, opens offline) for a finished\n"
      "estimation job: measured vs simulated paths of the evaluation points, the coefficients with\n"
      "the combinations the data determine, E along the scale ray, E over the Phase 1 grid as 2-D\n"
      "slices through the optimum, friction forces over time, and the diagnosis when given.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("report", args.status());
  if (args->positionals().size() != 1)
    return Fail("report", Status::InvalidArgument("expected one job ID (see --help)"));
  auto id = ParseJobId(args->positionals(), 0);
  if (!id.ok()) return Fail("report", id.status());
  auto out = args->Require("out");
  if (!out.ok()) return Fail("report", out.status());
  std::string diagnosis;
  if (args->Has("diagnosis")) {
    auto text = ReadFile(args->Get("diagnosis"));
    if (!text.ok()) return Fail("report", text.status());
    auto j = nlohmann::json::parse(*text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      return Fail("report", Status::InvalidArgument(args->Get("diagnosis") + ": not a JSON object (expected the output "
                                                                             "of wormdrag diagnose --json)"));
    diagnosis = *text;
  }
  const std::string db = DefaultDbPath(*args);
  auto store = JobStore::Open(db);
  if (!store.ok()) return Fail("report", store.status());
  auto data = CollectReport(**store, *id);
  if (!data.ok()) return Fail("report", data.status());
  data->diagnosis_json = diagnosis;
  data->source_label = db;
  Status st = WriteFileAtomically(*out, RenderReportHtml(*data));
  if (!st.ok()) return Fail("report", st);
  std::fprintf(stderr, "wrote %s (job %lld, E = %.4g %% of body length)\n", out->c_str(), static_cast<long long>(*id),
               data->job.e_percent);
  return 0;
}

}  // namespace wormdrag::cli
