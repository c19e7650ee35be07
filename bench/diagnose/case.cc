// One pair in full: --case SEED (a benchmark case, its outcome optionally appended to a
// state) and --single (one diagnosis of the timed pair, 2 × 5 s at 300 fps by default).
#include <chrono>
#include <cstdio>
#include <fstream>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int RunOneCase(const Bench& b) {
  const flags::Args& args = b.args;
  const int seed = static_cast<int>(Arg(args, "--case", -1));
  Case c;
  if (!CaseBySeed(seed, &c)) {
    std::fprintf(stderr, "no benchmark case %d\n", seed);
    return 2;
  }
  Outcome x = RunCase(c, b.src, b.o, b.fps, b.duration, Arg(args, "--noise", 0.002));
  std::printf("%s\n%s\n", Dump(SummaryJson(x)).c_str(), x.ok ? x.d.ToText().c_str() : x.error.c_str());
  // --state PATH: the outcome appended as a scoring line (to run a set pair by pair).
  if (const std::string path = ArgS(args, "--state", ""); !path.empty()) {
    CreateParentFolder(path);
    std::ofstream state(path, std::ios::app);
    state << StateOf("score", x).dump() << std::endl;
    if (!state) {
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
      return 1;
    }
  }
  return x.ok ? 0 : 1;
}

int RunSingle(const Bench& b) {
  const flags::Args& args = b.args;
  DiagnoseOptions o = b.o;
  Case c = MakeCases(1)[15];
  const double sfps = Arg(args, "--fps", 300), sdur = Arg(args, "--duration", 5);
  o.t_max = sdur;
  const auto tp = std::chrono::steady_clock::now();
  std::string last;
  o.progress = [&](const std::string& stage, double) {
    if (stage == last) return;
    last = stage;
    std::fprintf(stderr, "%7.1f s  %s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - tp).count(),
                 stage.c_str());
  };
  const auto t0 = std::chrono::steady_clock::now();
  Outcome x = RunCase(c, b.src, o, sfps, sdur);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s\n%s\n%.1f s for one diagnosis (%g fps, %g s, %d null replicates, %d threads)\n",
              Dump(SummaryJson(x)).c_str(), x.ok ? x.d.ToText().c_str() : x.error.c_str(), s, sfps, sdur,
              o.null_replicates, o.threads);
  return x.ok ? 0 : 1;
}

}  // namespace wormdrag::diagnose_bench
