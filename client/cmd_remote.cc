// wormdrag submit / watch / cancel, and the remote halves of `jobs` and `results`:
// the same commands against a wormdrag-server (--server or $WORMDRAG_SERVER) or,
// without a server, against the embedded job store.
#include <chrono>
#include <cstdio>
#include <sstream>
#include <thread>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/progress.h"
#include "client/remote_client.h"
#include "client/result_text.h"
#include "client/results_table.h"
#include "core/store/job_store.h"
#include "proto/convert.h"

namespace wormdrag::cli {

namespace {

namespace v2 = wormdrag::v2;

using remote::Config;
using remote::PrintResult;
using remote::Remote;
using remote::Rpc;
using remote::StateName;
using remote::Stub;
using remote::WatchRemote;
using remote::With;

// Sends a submission with the two recordings, reports the job ID, and with --wait
// follows the job and prints its result.
int SubmitAndFollow(const Args& args, const rpc::ClientConfig& c, const std::array<JobInput, 2>& inputs,
                    v2::SubmitJobRequest req, const char* cmd, bool print_json, const std::string& save_json) {
  auto stub = Stub(c);
  if (!stub.ok()) return Fail(cmd, stub.status());
  req.mutable_recording1()->set_name(inputs[0].name);
  req.mutable_recording1()->set_content(inputs[0].content);
  req.mutable_recording2()->set_name(inputs[1].name);
  req.mutable_recording2()->set_content(inputs[1].content);
  v2::SubmitJobResponse resp;
  grpc::ClientContext ctx;
  rpc::Prepare(&ctx, c.token, 60);
  grpc::Status st = (*stub)->SubmitJob(&ctx, req, &resp);
  if (!st.ok()) return Fail(cmd, Rpc(st, c));
  std::fprintf(stderr, "wormdrag %s: job %lld on %s%s\n", cmd, static_cast<long long>(resp.job_id()), c.server.c_str(),
               resp.reused() ? " (finished earlier with the same inputs and options)" : "");
  if (!args.Has("wait")) {
    std::printf("%lld\n", static_cast<long long>(resp.job_id()));
    return 0;
  }
  const int rc = WatchRemote(**stub, c, resp.job_id(), cmd);
  if (rc != 0) return rc;
  return PrintResult(**stub, c, resp.job_id(), print_json, cmd, save_json);
}

}  // namespace

int SubmitDiagnosisRemote(const Args& args, const std::array<JobInput, 2>& inputs, const diagnose::DiagnoseOptions& o) {
  const char* cmd = "diagnose";
  if (args.Has("report"))
    return Fail(cmd,
                Status::InvalidArgument("--report is for embedded runs; with --server save --json OUT (an estimate's "
                                        "report includes it: `wormdrag report ID --diagnosis OUT`)"));
  if (args.Has("threads"))
    return Fail(cmd, Status::InvalidArgument("--threads is for embedded runs; workers choose their own"));
  v2::SubmitJobRequest req;
  rpc::DiagnoseOptionsToProto(o, req.mutable_diagnose());
  auto c = Config(args);
  if (!c.ok()) return Fail(cmd, c.status());
  return SubmitAndFollow(args, *c, inputs, std::move(req), cmd, false, args.Get("json"));
}

bool WantsServer(const std::vector<std::string>& cmdline) {
  const std::string first = flags::FirstOption(cmdline, {"server", "db"});
  if (!first.empty()) return first == "server";
  return !rpc::EnvOr(rpc::kServerEnv, "").empty();
}

int RunSubmit(const std::vector<std::string>& cmdline) {
  std::vector<Option> specs = With({
      {"wait", "", "follow the job (progress bar) and print its result", ""},
      {"json", "", "with --wait: print the result as JSON on stdout", ""},
      {"no-reuse", "", "run again even if the same inputs and options were estimated before", ""},
      {"threads", "N", "embedded only: worker threads", "all cores"},
  });
  for (const auto& list : {InputOptionSpecs(), JobOptionSpecs()}) specs.insert(specs.end(), list.begin(), list.end());
  const std::string usage = Usage(
      "wormdrag submit", "K1.csv K2.csv [--server HOST:PORT] [--wait] [options]",
      "Submits an estimation job to a wormdrag-server and prints its ID (with --wait, follows\n"
      "it and prints the result). Without --server (or $WORMDRAG_SERVER) the job runs in this\n"
      "process on the embedded job store, exactly as `wormdrag estimate`.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("submit", args.status());
  if (!Remote(*args)) {
    // Embedded: the estimate command is the embedded coordinator and worker in one.
    std::vector<std::string> keep;
    for (const auto& a : cmdline)
      if (a != "--wait") keep.push_back(a);
    return RunEstimate(keep);
  }
  if (args->Has("threads"))
    return Fail("submit", Status::InvalidArgument("--threads is for embedded runs; workers choose their own"));
  auto c = Config(*args);
  if (!c.ok()) return Fail("submit", c.status());
  auto inputs = ReadJobInputs(*args);
  if (!inputs.ok()) return Fail("submit", inputs.status());
  auto options = JobOptionsFromArgs(*args);
  if (!options.ok()) return Fail("submit", options.status());
  v2::SubmitJobRequest req;
  rpc::OptionsToProto(*options, req.mutable_options());
  req.set_reuse(!args->Has("no-reuse"));
  return SubmitAndFollow(*args, *c, *inputs, std::move(req), "submit", args->Has("json"), "");
}

int RunWatch(const std::vector<std::string>& cmdline) {
  const auto specs = With({{"result", "", "print the result when the job is done", ""}});
  const std::string usage = Usage(
      "wormdrag watch", "ID [--server HOST:PORT]",
      "Follows a job until it ends: phase, progress bar, tasks, workers, rate, ETA and best E.\n"
      "Exit code 0 when the job is done, 1 when it failed or was cancelled.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("watch", args.status());
  auto id = ParseJobId(args->positionals(), 0);
  if (!id.ok()) return Fail("watch", id.status());
  if (Remote(*args)) {
    auto config = Config(*args);
    if (!config.ok()) return Fail("watch", config.status());
    const rpc::ClientConfig& c = *config;
    auto stub = Stub(c);
    if (!stub.ok()) return Fail("watch", stub.status());
    const int rc = WatchRemote(**stub, c, *id, "watch");
    if (rc != 0 || !args->Has("result")) return rc;
    return PrintResult(**stub, c, *id, false, "watch");
  }
  // Embedded: another process (wormdrag estimate / submit) runs the job; follow the store.
  auto store = JobStore::Open(DefaultDbPath(*args));
  if (!store.ok()) return Fail("watch", store.status());
  ProgressBar bar(StderrIsTerminal());
  for (;;) {
    auto j = (*store)->GetJob(*id);
    if (!j.ok()) return Fail("watch", j.status());
    if (j->sets_total > 0) bar.Update(j->phase, j->sets_done, j->sets_total, j->best_e);
    if (j->state == JobState::kDone || j->state == JobState::kFailed || j->state == JobState::kCancelled) {
      bar.Finish();
      std::fprintf(stderr, "wormdrag watch: job %lld %s%s%s\n", static_cast<long long>(*id), JobStateName(j->state),
                   j->error.empty() ? "" : ": ", j->error.c_str());
      if (j->state == JobState::kDone && args->Has("result")) {
        auto result = TypedResult(j->kind, j->result_json);
        if (!result.ok()) return Fail("watch", result.status().Annotate("job " + std::to_string(*id)));
        std::printf("job %lld\n%s", static_cast<long long>(*id), ResultText(*result).c_str());
      }
      return j->state == JobState::kDone ? 0 : 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

int RunCancel(const std::vector<std::string>& cmdline) {
  const auto specs = With({});
  const std::string usage = Usage("wormdrag cancel", "ID [--server HOST:PORT]",
                                  "Cancels a queued or running job: its tasks stop, its stored evaluations are kept.",
                                  specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("cancel", args.status());
  auto id = ParseJobId(args->positionals(), 0);
  if (!id.ok()) return Fail("cancel", id.status());
  if (Remote(*args)) {
    auto config = Config(*args);
    if (!config.ok()) return Fail("cancel", config.status());
    const rpc::ClientConfig& c = *config;
    auto stub = Stub(c);
    if (!stub.ok()) return Fail("cancel", stub.status());
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, c.token, 30);
    v2::CancelJobRequest req;
    req.set_job_id(*id);
    v2::CancelJobResponse resp;
    grpc::Status st = (*stub)->CancelJob(&ctx, req, &resp);
    if (!st.ok()) return Fail("cancel", Rpc(st, c));
  } else {
    auto store = JobStore::Open(DefaultDbPath(*args));
    if (!store.ok()) return Fail("cancel", store.status());
    auto j = (*store)->GetJob(*id);
    if (!j.ok()) return Fail("cancel", j.status());
    if (j->state == JobState::kDone || j->state == JobState::kFailed || j->state == JobState::kCancelled)
      return Fail("cancel", Status::FailedPrecondition("job " + std::to_string(*id) + " has already ended (" +
                                                       JobStateName(j->state) + ")"));
    // The process running it polls the stored state and stops.
    if (Status st = (*store)->SetState(*id, JobState::kCancelled, "cancelled by user"); !st.ok())
      return Fail("cancel", st);
  }
  std::fprintf(stderr, "wormdrag cancel: job %lld cancelled\n", static_cast<long long>(*id));
  return 0;
}

int RunJobsRemote(const std::vector<std::string>& cmdline) {
  const auto specs = With({{"limit", "N", "list at most N jobs, newest first", "50"}});
  const std::string usage = Usage("wormdrag jobs", "list | show ID --server HOST:PORT",
                                  "Lists the jobs of a wormdrag-server, or shows one job.", specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("jobs", args.status());
  const auto& pos = args->positionals();
  if (pos.empty() || (pos[0] != "list" && pos[0] != "show"))
    return Fail("jobs", Status::InvalidArgument("expected 'jobs list' or 'jobs show ID' (see --help)"));
  auto config = Config(*args);
  if (!config.ok()) return Fail("jobs", config.status());
  const rpc::ClientConfig& c = *config;
  auto stub = Stub(c);
  if (!stub.ok()) return Fail("jobs", stub.status());
  auto progress = [](const v2::Job& j) -> std::string {
    if (j.state() == v2::JOB_STATE_DONE || j.sets_total() == 0) return "";
    return j.phase() + " " + std::to_string(j.sets_done()) + "/" + std::to_string(j.sets_total());
  };
  if (pos[0] == "list") {
    auto limit = args->GetIntIn("limit", 50, 1, 1000000);
    if (!limit.ok()) return Fail("jobs", limit.status());
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, c.token, 30);
    v2::ListJobsRequest req;
    req.set_limit(static_cast<int>(*limit));
    v2::ListJobsResponse resp;
    grpc::Status st = (*stub)->ListJobs(&ctx, req, &resp);
    if (!st.ok()) return Fail("jobs", Rpc(st, c));
    std::printf("%-5s %-9s %-9s %-20s %-12s %-24s %s\n", "ID", "KIND", "STATE", "CREATED (UTC)", "BEST E mm",
                "PROGRESS", "INPUTS");
    for (const auto& j : resp.jobs())
      std::printf("%-5lld %-9s %-9s %-20s %-12s %-24s %s %s\n", static_cast<long long>(j.id()), "estimate",
                  StateName(j.state()), j.created_at().substr(0, 19).c_str(), FormatE(j.best_e()).c_str(),
                  progress(j).c_str(), j.dataset_names_size() > 0 ? j.dataset_names(0).c_str() : "",
                  j.dataset_names_size() > 1 ? j.dataset_names(1).c_str() : "");
    return 0;
  }
  auto id = ParseJobId(pos, 1);
  if (!id.ok()) return Fail("jobs", id.status());
  grpc::ClientContext ctx;
  rpc::Prepare(&ctx, c.token, 30);
  v2::GetResultsRequest req;
  req.set_job_id(*id);
  v2::GetResultsResponse resp;
  grpc::Status st = (*stub)->GetResults(&ctx, req, &resp);
  if (!st.ok()) return Fail("jobs", Rpc(st, c));
  const v2::Job& j = resp.job();
  std::printf("job %lld (%s): %s\ncreated %s, updated %s\n", static_cast<long long>(j.id()), j.kind().c_str(),
              StateName(j.state()), j.created_at().c_str(), j.updated_at().c_str());
  for (int k = 0; k < j.dataset_names_size() && k < j.dataset_hashes_size(); ++k)
    std::printf("input %d: %s (sha256 %s)\n", k + 1, j.dataset_names(k).c_str(), j.dataset_hashes(k).c_str());
  const Result<std::string> options = rpc::JobOptionsText(j);
  std::printf("options: %s\n", options.ok() ? options->c_str() : "");
  if (!progress(j).empty())
    std::printf("progress: %s, best E %s mm\n", progress(j).c_str(), FormatE(j.best_e()).c_str());
  if (!j.error().empty()) std::printf("error: %s\n", j.error().c_str());
  if (j.state() == v2::JOB_STATE_DONE) std::printf("%s", ResultText(resp).c_str());
  return 0;
}

int RunResultsRemote(const std::vector<std::string>& cmdline) {
  const auto specs = With(ResultsOptionSpecs());
  const std::string usage = Usage("wormdrag results", "ID --server HOST:PORT [options]",
                                  "Prints the evaluated coefficient sets of a job on a wormdrag-server, best first,\n"
                                  "or its Phase 1/2 survivors.",
                                  specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("results", args.status());
  auto q = ParseResultsQuery(*args);
  if (!q.ok()) return Fail("results", q.status());
  auto config = Config(*args);
  if (!config.ok()) return Fail("results", config.status());
  const rpc::ClientConfig& c = *config;
  auto stub = Stub(c);
  if (!stub.ok()) return Fail("results", stub.status());
  std::vector<EvaluationRecord> rows;
  if (q->survivors) {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, c.token, 30);
    v2::GetResultsRequest req;
    req.set_job_id(q->job);
    v2::GetResultsResponse resp;
    grpc::Status st = (*stub)->GetResults(&ctx, req, &resp);
    if (!st.ok()) return Fail("results", Rpc(st, c));
    for (const auto& e : q->phase == 1 ? resp.survivors1() : resp.survivors2())
      rows.push_back({e.phase(), {e.mu_n(), e.mu_t(), e.eta_n(), e.eta_t()}, e.e()});
  } else {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, c.token, 300);
    v2::ExportResultsRequest req;
    req.set_job_id(q->job);
    auto reader = (*stub)->ExportResults(&ctx, req);
    v2::ExportChunk chunk;
    std::string csv;
    while (reader->Read(&chunk)) csv += chunk.data();
    grpc::Status st = reader->Finish();
    if (!st.ok()) return Fail("results", Rpc(st, c));
    std::istringstream in(csv);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      EvaluationRecord r;
      if (std::sscanf(line.c_str(), "%d,%lf,%lf,%lf,%lf,%lf", &r.phase, &r.set.mu_n, &r.set.mu_t, &r.set.eta_n,
                      &r.set.eta_t, &r.e) != 6)
        continue;
      if (q->phase != 0 && r.phase != q->phase) continue;
      rows.push_back(r);
      if (q->top > 0 && static_cast<int64_t>(rows.size()) >= q->top) break;
    }
  }
  if (q->top > 0 && static_cast<int64_t>(rows.size()) > q->top) rows.resize(q->top);
  PrintResults(q->job, rows, q->format);
  return 0;
}

}  // namespace wormdrag::cli
