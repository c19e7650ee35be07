// Noise benchmark (docs/estimation.md, "Noise benchmark"): the estimator on pairs made
// the way real data are made — simulated by the diagnosis's own simulator with the
// joint angles moving between frames (the paper's pattern, or real joint angles from a
// kymogram), Gaussian tracking noise on every point — run through the whole job
// pipeline with the chosen options, scored against the truth.
//
//   noise_bench run [--mode after|before] [--regimes agar,water,mixed] [--noise 0,0.2,0.5,1]
//                   [--drives pattern,real] [--seeds 5] [--first-seed 1] [--fps 300] [--duration 5] [--threads N]
//                   [--out build/noise_bench/results.jsonl]
//   noise_bench summary [--out …]
//
// `run` appends one JSON line per case and skips cases already in the file, so an
// interrupted run continues. `before` is the estimator's previous default (the paper's
// 5 Hz low-pass, no bootstrap; its "interval" is the curvature tolerance it printed).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/common/flags.h"
#include "core/common/format.h"

#include "bench/noise_pairs.h"
#include "core/jobs/bootstrap_run.h"
#include "core/jobs/estimate_job.h"

using namespace wormdrag;
using nlohmann::json;

namespace {

using bench::Regime;

const char* const kDefaultOut = "build/noise_bench/results.jsonl";

flags::Spec RunSpec() {
  return {
      "noise_bench run",
      "[--mode after|before] [--regimes agar,water,mixed] [--noise 0,0.2,0.5,1] [--drives pattern,real]\n"
      "       [--seeds 5] [--first-seed 1] [--fps 300] [--duration 5] [--threads N] [--out FILE]",
      "Estimates every case (regime x noise x drive x seed) and appends one JSON line per case\n"
      "to --out, skipping cases already there, so an interrupted run continues.",
      {{"mode", "after|before", "the estimator's default options, or its previous default (5 Hz low-pass)", "after"},
       {"regimes", "LIST", "friction regimes", "agar,water,mixed"},
       {"noise", "LIST", "tracking noise, % of the body length", "0,0.2,0.5,1"},
       {"drives", "LIST", "joint angles: the paper's pattern, a real kymogram", "pattern,real"},
       {"drive-cutoff", "HZ", "low-pass the real kymogram at HZ before it drives the truth (0: raw)", "0"},
       {"seeds", "N", "seeds per case", "5"},
       {"first-seed", "N", "the first seed", "1"},
       {"fps", "F", "frame rate", "300"},
       {"duration", "S", "length of each recording", "5"},
       {"threads", "N", "worker threads", "all cores"},
       {"out", "FILE", "results, one JSON line per case", kDefaultOut}},
      false};
}

flags::Spec SummarySpec() {
  return {"noise_bench summary",
          "[--out FILE]",
          "Tables of the results in --out.",
          {{"out", "FILE", "results of noise_bench run", kDefaultOut}},
          false};
}

double CombinationOf(const Coefficients& c, const std::string& name) {
  if (name == "K_mu") return c.K_mu();
  if (name == "K_eta") return c.K_eta();
  return c.v_c();
}

int Run(const flags::Args& args) {
  const std::string mode = args.Get("mode", "after");
  const std::string out = args.Get("out", kDefaultOut);
  const auto seeds = args.GetInt("seeds", 5);
  const auto first_seed = args.GetInt("first-seed", 1);
  const auto fps = args.GetDouble("fps", 300);
  const auto duration = args.GetDouble("duration", 5);
  const auto threads = args.GetInt("threads", DefaultThreads());
  const auto drive_cutoff = args.GetDouble("drive-cutoff", 0);
  for (const Status& st :
       {seeds.status(), first_seed.status(), fps.status(), duration.status(), threads.status(), drive_cutoff.status()})
    if (!st.ok()) return flags::Fail("noise_bench", st);
  std::vector<double> noises;
  for (const std::string& n : SplitList(args.Get("noise", "0,0.2,0.5,1"))) {
    double v = 0;
    if (!flags::ToDouble(n, &v) || !(v >= 0))
      return flags::Fail("noise_bench", Status::InvalidArgument("--noise: not a noise level >= 0: '" + n + "'"));
    noises.push_back(v);
  }
  std::filesystem::create_directories(std::filesystem::path(out).parent_path());
  std::set<std::string> done;
  {
    std::ifstream in(out);
    for (std::string line; std::getline(in, line);) {
      auto j = json::parse(line, nullptr, false);
      if (j.is_object()) done.insert(j.value("case", ""));
    }
  }
  Kinematics real;
  if (auto k = bench::RealShapes(*drive_cutoff); k.ok()) real = std::move(*k);
  for (const std::string& rname : SplitList(args.Get("regimes", "agar,water,mixed")))
    for (const double noise : noises)
      for (const std::string& drive : SplitList(args.Get("drives", "pattern,real")))
        for (int seed = static_cast<int>(*first_seed); seed < *first_seed + *seeds; ++seed) {
          const Regime* r = bench::FindRegime(rname);
          if (!r) return std::fprintf(stderr, "noise_bench: unknown regime %s\n", rname.c_str()), 2;
          // A low-passed real drive is a drive of its own in the results.
          const std::string label = drive == "real" && *drive_cutoff > 0 ? "real-lp" + FormatNumber(*drive_cutoff, 4)
                                                                         : drive;
          char id[200];
          std::snprintf(id, sizeof id, "%s/%s/noise%s/%s/fps%g/%gs/seed%d", mode.c_str(), rname.c_str(),
                        FormatNumber(noise, 6).c_str(), label.c_str(), *fps, *duration, seed);
          if (done.count(id)) continue;
          if (drive == "real" && real.frames.empty()) {
            std::fprintf(stderr, "noise_bench: no real kymogram under %s; skipping %s\n", WORMDRAG_SHARED_DIR, id);
            continue;
          }
          auto made = bench::SynthesizePair(r->truth, drive, noise, seed, seed, *fps, *duration, &real);
          if (!made.ok()) return std::fprintf(stderr, "%s: %s\n", id, made.status().ToString().c_str()), 1;
          const std::array<Kinematics, 2> pair = {(*made)[0].recording, (*made)[1].recording};
          JobOptions o;
          if (mode == "before") {
            o.smoothing = SmoothingMethod::kLowpass;
            o.bootstrap.replicates = 0;
          }
          o.estimate.eval.t_max = *duration;
          const std::string db = out + ".db";
          // A run that was killed leaves its write-ahead log beside the store.
          for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(db + suffix);
          auto store = JobStore::Open(db);
          if (!store.ok()) return std::fprintf(stderr, "%s\n", store.status().ToString().c_str()), 1;
          bool reused = false;
          auto job = SubmitEstimateJob(
              **store, {JobInput{"w1", FormatKinematics(pair[0])}, JobInput{"w2", FormatKinematics(pair[1])}}, o, false,
              &reused);
          json line = {{"case", id},
                       {"mode", mode},
                       {"regime", rname},
                       {"noise_bl", noise},
                       {"drive", label},
                       {"seed", seed},
                       {"determines", r->determines},
                       {"truth", {r->truth.mu_n, r->truth.mu_t, r->truth.eta_n, r->truth.eta_t}}};
          if (!job.ok()) {
            line["error"] = job.status().ToString();
          } else {
            Status st = RunEstimateJob(**store, *job, LocalEvaluatorFactory(static_cast<int>(*threads)), {},
                                       LocalReplicateRunner(static_cast<int>(*threads)));
            auto rec = (*store)->GetJob(*job);
            if (!st.ok() || !rec.ok())
              line["error"] = st.ok() ? rec.status().ToString() : st.ToString();
            else
              line["result"] = json::parse(rec->result_json);
          }
          std::ofstream(out, std::ios::app) << line.dump() << "\n";
          std::fprintf(stderr, "noise_bench: %s done\n", id);
        }
  return 0;
}

// One case's verdict on the combination its regime determines.
struct Score {
  double error_pct = NAN;   // |estimate − truth| / truth
  bool determined = false;  // claimed (interval within the bounds, or "before": a finite tolerance)
  bool covered = false;     // the truth inside the claimed interval
  bool off_by_2 = false;    // a determined claim whose interval misses the truth by more than 2×
};

Score ScoreCase(const json& c) {
  Score s;
  const auto& res = c["result"];
  const std::string name = c["determines"];
  const auto t = c["truth"];
  const double truth = CombinationOf({t[0], t[1], t[2], t[3]}, name);
  const auto& e = res["estimate"];
  auto num = [](const json& v) { return v.is_number() ? v.get<double>() : NAN; };
  const double est = CombinationOf({num(e["mu_n"]), num(e["mu_t"]), num(e["eta_n"]), num(e["eta_t"])}, name);
  s.error_pct = std::isfinite(est) ? 100 * std::abs(est - truth) / truth : INFINITY;
  double lo = NAN, hi = NAN;
  if (res.contains("bootstrap")) {
    const auto& b = res["bootstrap"][name];
    s.determined = b.value("determined", false);
    // What the user is shown: the bias-corrected value when determined.
    if (s.determined && b.contains("corrected")) s.error_pct = 100 * std::abs(num(b["corrected"]) - truth) / truth;
    // A null end reaches the bound: stored results may carry null where the refits'
    // median lay at a bound.
    lo = b["lo"].is_null() ? 0 : num(b["lo"]);
    hi = b["hi"].is_string() || b["hi"].is_null() ? INFINITY : num(b["hi"]);
  } else if (res.contains("identifiability")) {
    const double tol = num(res["identifiability"]["tolerance"][name]);
    s.determined = std::isfinite(tol) && std::isfinite(est) && res.value("explains_motion", true);
    lo = est * (1 - tol);
    hi = est * (1 + tol);
  }
  if (!res.value("explains_motion", true)) s.determined = false;
  s.covered = lo <= truth && truth <= hi;
  s.off_by_2 = s.determined && (truth > 2 * hi || truth < lo / 2);
  return s;
}

int Summary(const flags::Args& args) {
  const std::string out = args.Get("out", kDefaultOut);
  std::ifstream in(out);
  if (!in) return std::fprintf(stderr, "noise_bench: cannot read %s\n", out.c_str()), 2;
  std::map<std::string, std::vector<json>> groups;
  for (std::string line; std::getline(in, line);) {
    auto j = json::parse(line, nullptr, false);
    if (!j.is_object()) continue;
    char key[160];
    std::snprintf(key, sizeof key, "| %s | %s | %s | %g |", j.value("mode", "").c_str(), j.value("regime", "").c_str(),
                  j.value("drive", "").c_str(), j.value("noise_bl", 0.0));
    groups[key].push_back(j);
  }
  std::printf(
      "| mode | regime | drive | noise %% BL | cases | determines | median error %% | determined | "
      "90 %% interval covers truth | determined and covering | determined and off by > 2x | failed |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [key, cases] : groups) {
    std::vector<double> errors;
    int determined = 0, covered = 0, claims_covered = 0, off = 0, failed = 0;
    std::string what;
    for (const auto& c : cases) {
      what = c.value("determines", "");
      if (c.contains("error")) {
        ++failed;
        continue;
      }
      const Score s = ScoreCase(c);
      errors.push_back(s.error_pct);
      determined += s.determined;
      covered += s.covered;
      claims_covered += s.determined && s.covered;
      off += s.off_by_2;
    }
    std::sort(errors.begin(), errors.end());
    const double median = errors.empty() ? NAN : errors[errors.size() / 2];
    const int n = static_cast<int>(errors.size());
    std::printf("%s %zu | %s | %.3g | %d/%d | %d/%d | %d/%d | %d | %d |\n", key.c_str(), cases.size(), what.c_str(),
                median, determined, n, covered, n, claims_covered, determined, off, failed);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> words = flags::ArgList(argc, argv);
  const std::string cmd = words.empty() ? "" : words[0];
  const std::vector<std::string> rest(words.begin() + !words.empty(), words.end());
  flags::Args args;
  if (cmd == "run" || cmd == "summary") {
    const flags::Spec spec = cmd == "run" ? RunSpec() : SummarySpec();
    if (auto rc = flags::Parse(rest, spec, &args)) return *rc;
    return cmd == "run" ? Run(args) : Summary(args);
  }
  const std::string usage = flags::Usage(RunSpec()) + "\n" + flags::Usage(SummarySpec());
  const bool help = cmd == "--help" || cmd == "-h";
  std::fputs(usage.c_str(), help ? stdout : stderr);
  return help ? 0 : 2;
}
