// wormdrag estimate: the whole pipeline in one process, recorded in a SQLite store.
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>

#include <nlohmann/json.hpp>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/progress.h"
#include "core/common/guard.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::cli {
namespace {

std::atomic<bool> g_interrupted{false};
void OnInterrupt(int) {
  g_interrupted = true;
}

}  // namespace

std::string FormatResultText(const std::string& result_json) {
  auto j = nlohmann::json::parse(result_json, nullptr, false);
  if (j.is_discarded()) return "(unreadable result)\n";
  std::string s;
  char buf[512];
  auto num = [](const nlohmann::json& v) { return v.is_number() ? v.get<double>() : NAN; };
  const auto& est = j["estimate"];
  std::snprintf(buf, sizeof buf,
                "friction per link: mu_n = %.6g uN, mu_t = %.6g uN, eta_n = %.6g uN.s/mm, eta_t = %.6g uN.s/mm\n"
                "path error E = %.6g mm = %.4g %% of body length\n",
                num(est["mu_n"]), num(est["mu_t"]), num(est["eta_n"]), num(est["eta_t"]), num(est["E_mm"]),
                num(j["E_percent_BL"]));
  s += buf;
  for (const auto& p : j["phases"]) {
    std::snprintf(buf, sizeof buf, "  %-14s %8lld sets  %7.1f s  best E %.6g mm", p["name"].get<std::string>().c_str(),
                  static_cast<long long>(p["sets"].get<int64_t>()), num(p["seconds"]), num(p["best"]["E_mm"]));
    s += buf;
    // Phases 1-2: the work early abandoning saved (absent in results stored before it).
    const int64_t full = p.value("knots_full", int64_t{0});
    if (full > 0) {
      const int64_t knots = p.value("knots", int64_t{0});
      std::snprintf(buf, sizeof buf, "  %lld abandoned, knots %.4g of %.4g (%.1f %%)",
                    static_cast<long long>(p.value("abandoned", int64_t{0})), static_cast<double>(knots),
                    static_cast<double>(full), 100.0 * static_cast<double>(knots) / static_cast<double>(full));
      s += buf;
    }
    s += "\n";
  }
  if (j.contains("smoothing"))
    for (size_t w = 0; w < j["smoothing"].size(); ++w) {
      const auto& sm = j["smoothing"][w];
      std::snprintf(buf, sizeof buf, "worm %zu: %s; tracking noise %.3g um = %.3g %% BL", w + 1,
                    sm.value("method", std::string()).c_str(), num(sm["noise_um"]), num(sm["noise_percent_bl"]));
      s += buf;
      if (sm.value("runs", 0) > 0 && sm.value("method", std::string()).rfind("auto", 0) == 0) {
        std::snprintf(buf, sizeof buf, "; smoothing half-power %.3g Hz (range %.3g-%.3g)", num(sm["half_power_hz"]),
                      num(sm["half_power_hz_min"]), num(sm["half_power_hz_max"]));
        s += buf;
      }
      s += "\n";
    }
  if (j.contains("still_body")) {
    std::snprintf(buf, sizeof buf,
                  "a body that keeps its shapes but does not move: E = %.4g %% BL; skill of the fit %.3f\n",
                  num(j["still_body"]["E_percent_BL"]), num(j["skill"]));
    s += buf;
    if (j.contains("scale_bound")) s += "scale: " + j["scale_bound"].get<std::string>() + "\n";
    if (!j.value("explains_motion", true)) {
      s += "The fit explains the motion no better than a body that does not move: the data determine no friction "
           "ratio here.\n";
      if (j.contains("reused_evaluations") && j["reused_evaluations"].get<int64_t>() > 0)
        s += "(" + std::to_string(j["reused_evaluations"].get<int64_t>()) + " Phase 1-2 evaluations reused)\n";
      return s;
    }
  }
  const auto& id = j["identifiability"];
  if (j.contains("bootstrap")) {
    const auto& b = j["bootstrap"];
    std::snprintf(buf, sizeof buf, "%.0f %% intervals from %d bootstrap refits with the estimated tracking noise:\n",
                  100 * num(b["level"]), b.value("replicates", 0));
    s += buf;
    for (const char* name : {"K_mu", "K_eta", "v_c", "scale"})
      s += IntervalLine(IntervalFromJson(name, b[name].dump()));
  } else {
    auto ratio = [&](const char* label, const nlohmann::json& v, const char* unit) {
      if (v.is_number() && std::isfinite(num(v)) && num(v) > 0)
        std::snprintf(buf, sizeof buf, " %s = %.6g%s", label, num(v), unit);
      else
        std::snprintf(buf, sizeof buf, " %s undefined", label);
      s += buf;
    };
    s += "identifiable (no intervals: --bootstrap 0):";
    ratio("K_mu = mu_n/mu_t", id["K_mu"], "");
    ratio(", K_eta = eta_n/eta_t", id["K_eta"], "");
    ratio(", v_c = mu_t/eta_t", id["v_c"], " mm/s");
    s += "\n";
  }
  s += "E along the scale ray (factor: E mm):";
  for (const auto& p : id["scale_profile"]) {
    std::snprintf(buf, sizeof buf, " %.3g:%.5g", num(p[0]), num(p[1]));
    s += buf;
  }
  s += "\n" + id.value("summary", std::string()) + "\n";
  if (j.contains("reused_evaluations") && j["reused_evaluations"].get<int64_t>() > 0)
    s += "(" + std::to_string(j["reused_evaluations"].get<int64_t>()) +
         " Phase 1-2 evaluations reused from the store)\n";
  return s;
}

int RunEstimate(const std::vector<std::string>& cmdline) {
  std::vector<Option> specs = {
      {"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"},
      {"threads", "N", "worker threads", "all cores"},
      {"json", "", "print the result as JSON on stdout", ""},
      {"no-reuse", "", "run again even if the same inputs and options were estimated before", ""},
  };
  const auto job_specs = JobOptionSpecs();
  specs.insert(specs.end(), job_specs.begin(), job_specs.end());
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
  auto inputs = ReadJobInputs(args->positionals());
  if (!inputs.ok()) return Fail("estimate", inputs.status());
  auto options = JobOptionsFromArgs(*args);
  if (!options.ok()) return Fail("estimate", options.status());
  auto threads = args->GetInt("threads", DefaultThreads());
  if (!threads.ok()) return Fail("estimate", threads.status());
  if (*threads < 1 || *threads > 1024) return Fail("estimate", Status::InvalidArgument("--threads must be 1-1024"));
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
  if (args->Has("json"))
    std::printf("%s\n", job->result_json.c_str());
  else
    std::printf("job %lld\n%s", static_cast<long long>(*id), FormatResultText(job->result_json).c_str());
  return 0;
}

}  // namespace wormdrag::cli
