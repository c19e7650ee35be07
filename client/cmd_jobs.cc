// wormdrag jobs list|show, wormdrag results: past jobs in the embedded job store.
#include <cmath>
#include <cstdio>
#include <cstring>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/result_text.h"
#include "client/results_table.h"
#include "core/common/json.h"
#include "core/store/job_store.h"

namespace wormdrag::cli {
namespace {

std::string Progress(const JobRecord& j) {
  if (j.state == JobState::kDone || j.sets_total == 0) return "";
  char buf[80];
  std::snprintf(buf, sizeof buf, "%s %lld/%lld", j.phase.c_str(), static_cast<long long>(j.sets_done),
                static_cast<long long>(j.sets_total));
  return buf;
}

}  // namespace

int RunJobs(const std::vector<std::string>& cmdline) {
  if (WantsServer(cmdline)) return RunJobsRemote(cmdline);
  const std::vector<Option> specs = {
      {"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"},
      {"limit", "N", "list at most N jobs, newest first", "50"},
  };
  const std::string usage = Usage("wormdrag jobs", "list | show ID [--db FILE | --server HOST:PORT]",
                                  "Lists the jobs of the job store, or shows one job: its inputs, options, state,\n"
                                  "progress and result. With --server (or $WORMDRAG_SERVER and no --db), asks a\n"
                                  "wormdrag-server instead (see wormdrag jobs --server X --help).",
                                  specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("jobs", args.status());
  const auto& pos = args->positionals();
  if (pos.empty() || (pos[0] != "list" && pos[0] != "show"))
    return Fail("jobs", Status::InvalidArgument("expected 'jobs list' or 'jobs show ID' (see --help)"));
  auto store = JobStore::Open(DefaultDbPath(*args));
  if (!store.ok()) return Fail("jobs", store.status());
  if (pos[0] == "list") {
    auto limit = args->GetIntIn("limit", 50, 1, 1000000);
    if (!limit.ok()) return Fail("jobs", limit.status());
    auto jobs = (*store)->ListJobs(static_cast<int>(*limit));
    if (!jobs.ok()) return Fail("jobs", jobs.status());
    std::printf("%-5s %-9s %-9s %-20s %-12s %-24s %s\n", "ID", "KIND", "STATE", "CREATED (UTC)", "BEST E mm",
                "PROGRESS", "INPUTS");
    for (const auto& j : *jobs)
      std::printf("%-5lld %-9s %-9s %-20s %-12s %-24s %s %s\n", static_cast<long long>(j.id), j.kind.c_str(),
                  JobStateName(j.state), j.created_at.substr(0, 19).c_str(), FormatE(j.best_e).c_str(),
                  Progress(j).c_str(), j.dataset_names[0].c_str(), j.dataset_names[1].c_str());
    return 0;
  }
  auto id = ParseJobId(pos, 1);
  if (!id.ok()) return Fail("jobs", id.status());
  auto j = (*store)->GetJob(*id);
  if (!j.ok()) return Fail("jobs", j.status());
  std::printf("job %lld (%s): %s\ncreated %s, updated %s\n", static_cast<long long>(j->id), j->kind.c_str(),
              JobStateName(j->state), j->created_at.c_str(), j->updated_at.c_str());
  for (int k = 0; k < 2; ++k)
    std::printf("input %d: %s (sha256 %s)\n", k + 1, j->dataset_names[k].c_str(), j->dataset_hashes[k].c_str());
  std::printf("options: %s\n", j->options_json.c_str());
  if (!Progress(*j).empty())
    std::printf("progress: %s, best E %s mm\n", Progress(*j).c_str(), FormatE(j->best_e).c_str());
  if (!j->error.empty()) std::printf("error: %s\n", j->error.c_str());
  auto n = (*store)->CountEvaluations(*id);
  if (n.ok()) std::printf("evaluated sets stored: %lld\n", static_cast<long long>(*n));
  if (j->state == JobState::kDone) {
    auto result = TypedResult(j->kind, j->result_json);
    if (!result.ok()) return Fail("jobs", result.status().Annotate("job " + std::to_string(*id)));
    std::printf("%s", ResultText(*result).c_str());
  }
  return 0;
}

int RunResults(const std::vector<std::string>& cmdline) {
  if (WantsServer(cmdline)) return RunResultsRemote(cmdline);
  std::vector<Option> specs = {{"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"}};
  const auto query_specs = ResultsOptionSpecs();
  specs.insert(specs.end(), query_specs.begin(), query_specs.end());
  const std::string usage = Usage("wormdrag results", "ID [options]",
                                  "Prints the evaluated coefficient sets of a job, best (lowest E) first, or its\n"
                                  "Phase 1/2 survivors; csv and json for further analysis. With --server (or\n"
                                  "$WORMDRAG_SERVER and no --db), asks a wormdrag-server instead.",
                                  specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("results", args.status());
  auto q = ParseResultsQuery(*args);
  if (!q.ok()) return Fail("results", q.status());
  auto store = JobStore::Open(DefaultDbPath(*args));
  if (!store.ok()) return Fail("results", store.status());
  auto job = (*store)->GetJob(q->job);
  if (!job.ok()) return Fail("results", job.status());
  Result<std::vector<EvaluationRecord>> rows = std::vector<EvaluationRecord>{};
  if (q->survivors)
    rows = (*store)->Survivors(q->job, q->phase);
  else
    rows = (*store)->Evaluations(q->job, q->phase, q->top);
  if (!rows.ok()) return Fail("results", rows.status());
  if (q->survivors && q->top > 0 && static_cast<int64_t>(rows->size()) > q->top) rows->resize(q->top);
  PrintResults(q->job, *rows, q->format);
  return 0;
}

Result<int64_t> ParseJobId(const std::vector<std::string>& pos, size_t index) {
  if (pos.size() <= index) return Status::InvalidArgument("missing job ID");
  char* end = nullptr;
  const long long v = std::strtoll(pos[index].c_str(), &end, 10);
  if (pos[index].empty() || *end != '\0' || v <= 0)
    return Status::InvalidArgument("job ID must be a positive number, got '" + pos[index] + "'");
  return static_cast<int64_t>(v);
}

std::vector<Option> ResultsOptionSpecs() {
  return {
      {"top", "K", "the K best sets (0 = all)", "20"},
      {"phase", "P", "only phase 1, 2 or 3 (0 = all)", "0"},
      {"survivors", "", "the d1 (phase 1) or d2 (phase 2) survivors instead of all sets", ""},
      {"format", "FMT", "text, csv or json", "text"},
  };
}

Result<ResultsQuery> ParseResultsQuery(const Args& args) {
  ResultsQuery q;
  auto id = ParseJobId(args.positionals(), 0);
  if (!id.ok()) return id.status();
  q.job = *id;
  auto top = args.GetIntIn("top", 20, 0, 1000000000), phase = args.GetIntIn("phase", 0, 0, 3);
  if (!top.ok()) return top.status();
  if (!phase.ok()) return phase.status();
  q.top = *top;
  q.phase = static_cast<int>(*phase);
  q.survivors = args.Has("survivors");
  if (q.survivors && q.phase != 1 && q.phase != 2)
    return Status::InvalidArgument("--survivors needs --phase 1 or --phase 2");
  q.format = args.Get("format", "text");
  if (q.format != "text" && q.format != "csv" && q.format != "json")
    return Status::InvalidArgument("--format must be text, csv or json, got '" + q.format + "'");
  return q;
}

std::string FormatE(double e) {
  if (!(e > 0) || !std::isfinite(e)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.5g", e);
  return buf;
}

void PrintResults(int64_t job, const std::vector<EvaluationRecord>& rows, const std::string& format) {
  auto e_text = [](double e) {
    if (!std::isfinite(e)) return std::string("inf");
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.10g", e);
    return std::string(buf);
  };
  if (format == "json") {
    Json out = Json::array();
    for (const auto& r : rows)
      out.push_back({{"phase", r.phase},
                     {"mu_n", r.set.mu_n},
                     {"mu_t", r.set.mu_t},
                     {"eta_n", r.set.eta_n},
                     {"eta_t", r.set.eta_t},
                     {"E_mm", NumberOrNull(r.e)}});
    std::printf("%s\n", Dump(out).c_str());
  } else if (format == "csv") {
    std::printf("phase,mu_n,mu_t,eta_n,eta_t,E_mm\n");
    for (const auto& r : rows)
      std::printf("%d,%.10g,%.10g,%.10g,%.10g,%s\n", r.phase, r.set.mu_n, r.set.mu_t, r.set.eta_n, r.set.eta_t,
                  e_text(r.e).c_str());
  } else {
    std::printf("job %lld: %zu sets, best first\n%-6s %-12s %-12s %-12s %-12s %s\n", static_cast<long long>(job),
                rows.size(), "PHASE", "mu_n uN", "mu_t uN", "eta_n", "eta_t", "E mm");
    for (const auto& r : rows)
      std::printf("%-6d %-12.6g %-12.6g %-12.6g %-12.6g %s\n", r.phase, r.set.mu_n, r.set.mu_t, r.set.eta_n,
                  r.set.eta_t, e_text(r.e).c_str());
  }
}

}  // namespace wormdrag::cli
