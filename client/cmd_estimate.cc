// wormdrag estimate: the whole pipeline in one process, recorded in a SQLite store.
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/progress.h"
#include "client/result_text.h"
#include "core/common/guard.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::cli {
namespace {

std::atomic<bool> g_interrupted{false};
void OnInterrupt(int) {
  g_interrupted = true;
}

}  // namespace

int RunEstimate(const std::vector<std::string>& cmdline) {
  std::vector<Option> specs = {
      {"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"},
      {"threads", "N", "worker threads", "all cores"},
      {"json", "", "print the result as JSON on stdout", ""},
      {"no-reuse", "", "run again even if the same inputs and options were estimated before", ""},
  };
  for (const auto& list : {InputOptionSpecs(), JobOptionSpecs()}) specs.insert(specs.end(), list.begin(), list.end());
  const std::string usage = Usage(
      "wormdrag estimate", "K1.csv K2.csv [options]",
      "Estimates the friction coefficients (mu_n, mu_t, eta_n, eta_t) that make the body model\n"
      "follow two recordings of worms in the same environment: Phase 1 grid, Phase 2 refinement,\n"
      "Phase 3 GRG, then the identifiability report. Runs in this process; the job, its inputs,\n"
      "every evaluated set, the survivors and the estimate are stored in the job store, and a\n"
      "repeated run of the same inputs and options reuses them (see wormdrag jobs, results).",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("estimate", args.status());
  auto inputs = ReadJobInputs(*args);
  if (!inputs.ok()) return Fail("estimate", inputs.status());
  auto options = JobOptionsFromArgs(*args);
  if (!options.ok()) return Fail("estimate", options.status());
  auto threads = args->GetIntIn("threads", DefaultThreads(), 1, 1024);
  if (!threads.ok()) return Fail("estimate", threads.status());
  const std::string db = DefaultDbPath(*args);
  auto store = JobStore::Open(db);
  if (!store.ok()) return Fail("estimate", store.status());
  bool reused = false;
  auto id = SubmitEstimateJob(**store, *inputs, *options, !args->Has("no-reuse"), &reused);
  if (!id.ok()) return Fail("estimate", id.status());
  if (reused) {
    std::fprintf(stderr,
                 "wormdrag estimate: same inputs and options as job %lld in %s: showing its result "
                 "(--no-reuse to run again)\n",
                 static_cast<long long>(*id), db.c_str());
  } else {
    std::fprintf(stderr, "wormdrag estimate: job %lld in %s, %ld threads\n", static_cast<long long>(*id), db.c_str(),
                 *threads);
    ProgressBar bar(StderrIsTerminal());
    JobHooks hooks;
    hooks.progress = [&](const std::string& phase, int64_t done, int64_t total, double best) {
      bar.Update(phase, done, total, best);
    };
    hooks.cancelled = [] { return g_interrupted.load(); };
    auto previous = std::signal(SIGINT, OnInterrupt);
    // As on the coordinator: an exception escaping the runner fails the job, so the
    // store never keeps it running with no runner.
    bool escaped = true;
    Status st = RunGuarded("job " + std::to_string(*id), [&] {
      Status s = RunEstimateJob(**store, *id, LocalEvaluatorFactory(static_cast<int>(*threads)), hooks);
      escaped = false;
      return s;
    });
    if (escaped) (void)(*store)->SetState(*id, JobState::kFailed, st.message());
    std::signal(SIGINT, previous);
    bar.Finish();
    if (!st.ok()) {
      if (st.code() == Status::Code::kCancelled) {
        std::fprintf(stderr,
                     "wormdrag estimate: interrupted; job %lld is marked cancelled, its evaluations are kept "
                     "and a new run reuses them\n",
                     static_cast<long long>(*id));
        return 130;
      }
      return Fail("estimate", st.Annotate("job " + std::to_string(*id)));
    }
  }
  auto job = (*store)->GetJob(*id);
  if (!job.ok()) return Fail("estimate", job.status());
  auto result = TypedResult(job->kind, job->result_json);
  if (!result.ok()) return Fail("estimate", result.status().Annotate("job " + std::to_string(*id)));
  if (args->Has("json"))
    std::printf("%s\n", ResultJson(*result).c_str());
  else
    std::printf("job %lld\n%s", static_cast<long long>(*id), ResultText(*result).c_str());
  return 0;
}

}  // namespace wormdrag::cli
