// Phase 3 with the Gauss–Newton Jacobian from finite differences and from the
// simulator's forward sensitivities, side by side (BENCHMARKS.md, "Phase 3 with exact
// derivatives"): Phase 3 of a pair from given starts, and one bootstrap replicate
// (FitReplicate: Phase 3 from the estimate on a noisy copy of the pair).
//   build/bench/phase3_bench K1.csv K2.csv --start MUN,MUT,ETAN,ETAT[;…] [--threads T] [--replicate N]
//                            [--jacobian fd|exact|both] [--smoothing none|auto|lowpass] [--scale-rounds R]
// Smoothing (default none: the recordings as read) applies to the pair and, as in a
// job, to each bootstrap replicate. Prints a Markdown table.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "core/common/flags.h"
#include "core/estimate/search.h"
#include "core/io/kinematics.h"
#include "core/jobs/bootstrap_run.h"

using namespace wormdrag;

namespace {

double CpuSeconds() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Clock {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  double cpu = CpuSeconds();
  void Print(const char* what, const char* mode, int64_t sets, const ScoredSet& best,
             const std::string& termination) const {
    const double w = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall).count();
    std::printf("| %s | %s | %lld | %.2f | %.2f | %.10g | %s |\n", what, mode, static_cast<long long>(sets), w,
                CpuSeconds() - cpu, best.e, best.set.ToString().c_str());
    std::fprintf(stderr, "%s, %s: %s\n", what, mode, termination.c_str());
    std::fflush(stdout);
  }
};

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{
      "phase3_bench",
      "K1.csv K2.csv --start MUN,MUT,ETAN,ETAT[;...] [--threads T] [--replicate N] [--jacobian fd|exact|both]\n"
      "       [--smoothing none|auto|lowpass] [--scale-rounds R]",
      "Phase 3 of a pair from given starts (or one bootstrap replicate) with finite-difference and\n"
      "exact Jacobians; prints a Markdown table (BENCHMARKS.md).",
      {{"start", "SETS", "Phase 3's starts, MUN,MUT,ETAN,ETAT separated by ';' (required)", ""},
       {"threads", "T", "worker threads", "all cores"},
       {"replicate", "N", "time bootstrap replicate N instead of Phase 3", ""},
       {"jacobian", "fd|exact|both", "which Jacobians", "both"},
       {"smoothing", "none|auto|lowpass", "smoothing of the pair and of each replicate", "none"},
       {"scale-rounds", "R", "GRG's limit of scale rounds", "the estimator's"}}};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const std::vector<std::string>& files = args.positionals();
  if (files.size() != 2) {
    std::fputs(flags::Usage(spec).c_str(), stderr);
    return 2;
  }
  const int threads = args.Has("threads") ? std::atoi(args.Get("threads").c_str()) : DefaultThreads();
  const int replicate = std::atoi(args.Get("replicate", "-1").c_str());
  const int scale_rounds = std::atoi(args.Get("scale-rounds", "-1").c_str());
  const std::string jacobian = args.Get("jacobian", "both"), smoothing = args.Get("smoothing", "none");
  std::vector<ScoredSet> starts;
  std::stringstream ss(args.Get("start"));
  for (std::string item; std::getline(ss, item, ';');) {
    auto c = ParseCoefficients(item);
    if (!c.ok()) {
      std::fprintf(stderr, "--start: %s\n", c.status().ToString().c_str());
      return 2;
    }
    starts.push_back({*c, 0});
  }
  if (starts.empty()) {
    std::fprintf(stderr, "--start is required\n");
    return 2;
  }
  JobOptions jo;
  auto method = ParseSmoothingMethod(smoothing);
  if (!method.ok()) {
    std::fprintf(stderr, "--smoothing: %s\n", method.status().ToString().c_str());
    return 2;
  }
  jo.smoothing = *method;
  std::array<Kinematics, 2> rec;
  for (int j = 0; j < 2; ++j) {
    auto k = ReadKinematics(files[j]);
    if (k.ok()) k = SmoothRecording(files[j], *k, jo);
    if (!k.ok()) {
      std::fprintf(stderr, "%s\n", k.status().ToString().c_str());
      return 2;
    }
    rec[j] = std::move(*k);
  }
  auto pair = PairedPath::Create(rec, {files[0], files[1]}, jo.estimate.eval);
  if (!pair.ok()) {
    std::fprintf(stderr, "%s\n", pair.status().ToString().c_str());
    return 2;
  }
  std::printf("| run | Jacobian | sets | wall s | CPU s | E mm | estimate |\n|---|---|---|---|---|---|---|\n");
  for (bool exact : {false, true}) {
    if (jacobian != "both" && jacobian != (exact ? "exact" : "fd")) continue;
    Phase3Options p3 = jo.estimate.phase3;
    p3.exact_jacobians = exact;
    if (scale_rounds >= 0) p3.scale_rounds = scale_rounds;  // GRG's limit (default 24)
    const char* mode = exact ? "exact" : "finite differences";
    if (replicate < 0) {
      LocalEvaluator ev(*pair, threads);
      PhaseSummary s;
      const Clock clock;
      auto best = RunPhase3(starts, jo.estimate.search, p3, ev, &s);
      if (!best.ok()) {
        std::fprintf(stderr, "%s\n", best.status().ToString().c_str());
        return 1;
      }
      clock.Print("Phase 3", mode, s.sets, *best, s.termination);
    } else {
      // As RunBootstrap: the noise is the floor (the example pair is noise-free).
      std::array<double, 2> noise;
      for (int j = 0; j < 2; ++j) noise[j] = jo.bootstrap.noise_floor_percent_bl / 100 * (*pair)->worm(j).body_length();
      jo.estimate.phase3 = p3;
      PhaseSummary s;
      const Clock clock;
      auto best = FitReplicate(**pair, {replicate, starts.front(), std::nullopt, noise}, jo, &s, threads);
      if (!best.ok()) {
        std::fprintf(stderr, "%s\n", best.status().ToString().c_str());
        return 1;
      }
      clock.Print("bootstrap replicate", mode, s.sets, *best, s.termination);
    }
  }
  return 0;
}
