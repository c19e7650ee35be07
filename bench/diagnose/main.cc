// The diagnosis benchmark's entry point: builds the options every mode shares from the
// command line and runs the mode asked for (one file per check under bench/diagnose/).
#include <algorithm>
#include <cstdio>
#include <cstring>

#include "bench/diagnose/bench.h"

using namespace wormdrag::diagnose_bench;

namespace {

constexpr const char* kUsage = R"(diagnose_bench: benchmark of the sim-to-real gap diagnosis (docs/diagnose.md, "Benchmark")

  diagnose_bench [options]            tune on seed set --tune-seed, score seed set --score-seed
  diagnose_bench --tune-only | --score-only [options]    one of the two sets
  diagnose_bench --redecide STATE     re-tune and re-score saved outcomes (no fits)
  diagnose_bench --single             time one diagnosis (2 x 5 s at 300 fps by default)
  diagnose_bench --case SEED          one benchmark case (SEED = set x 1000 + index); --state PATH appends its outcome
  diagnose_bench --fit-check SEED     base fits from the truth and from the start(s)
  diagnose_bench --fold-check SEED    the CV's base fold fits from its start, the truth and the leading effects' fits
  diagnose_bench --worm-check SEED [--effect NAME]   an effect (time_drift) fitted with one parameter for both worms
                 and with one per worm, on all blocks and on each half
  diagnose_bench --null-check | --resolution | --drive-check | --null-drive-check | --truth-check    measurements (docs/diagnose.md)
  diagnose_bench --noise-check [--effect NAME]   the true model of NAME [stiction] on its pairs and the none pairs of
                 --score-seed: held-out E at 0, 0.2 and 2 um of noise, noise-free with 4x the knots, and noise-free
                 on the continuous path (no pose restarts)
  diagnose_bench --profile-check [--effect NAME]   held-out E of NAME's [stiction] model along its parameter (the
                 true coefficients, 2 um of noise) on its pairs of --score-seed: is it smooth enough for the GRG?
  diagnose_bench --gap-check (--case SEED | --files K1.csv,K2.csv) [--coef MU_N,MU_T,ETA_N,ETA_T]   gap_offset's mark
                 in the residual of a base fit (a case's default: its truth's coefficients): one line
  diagnose_bench --simex (--files K1.csv,K2.csv --coef MU_N,MU_T,ETA_N,ETA_T | --case SEED) --noise SIGMA [--reps N]
                 gap_offset on a recorded pair with added noise (simulation-extrapolation)

Options (defaults in brackets):
  --fps F [100]  --duration S [3]  --null R [3]  --threads N [2]  --jobs J [1]
  --blocks B [6]  --iterations N [10]  --base-iterations N [150]  --no-grid
  --fit-hz H [30]  --substeps N [2]  --lowpass HZ [5]  --kymo-cutoff HZ [2.5]  --interpolate-gaps N [0]
  --gap-every S [0.25]  --cv-ridge W [0.5]  --refine-top N [1]  --no-base-multistart  --no-nested-fallback
  --tune-seed N [11]  --score-seed N [23]  --tune-limit N  --simex-draws N [3]  --simex-weight W [tuned]  --simex-min-keep K [0.3]
  --gap-signature-z Z [3]  --require-estimated 0|1 [1]  --clear-margin M [2]  --score-refined-fit 0|1 [tuned]  --excess-ratio R [tuned]  --out FILE [build/diagnose_bench/diagnose_bench.jsonl]  --state PATH [FILE.state]
  --case: --noise MM [0.002];  --null-check: --reps N [3] --noise MM [0.002] --coulomb-scale K [1];
  --drive-check: --coulomb-scale K [1] --cutoff HZ [5 and 3] --noise MM [0.0002, besides 0.002];  --null-drive-check: --reps N [2] --noise MM [0.002];  --resolution: --cases N [6]
)";

// Every argument must be a known flag or the value of a known option.
bool ArgsKnown(int argc, char** argv) {
  static const char* kValued[] = {"--fps", "--duration", "--null", "--threads", "--jobs", "--blocks", "--iterations",
                                  "--base-iterations", "--fit-hz", "--substeps", "--lowpass", "--kymo-cutoff", "--interpolate-gaps",
                                  "--gap-every", "--cv-ridge", "--refine-top", "--tune-seed", "--score-seed", "--simex-draws", "--simex-weight", "--simex-min-keep",
                                  "--gap-signature-z", "--require-estimated", "--clear-margin", "--score-refined-fit", "--excess-ratio", "--tune-limit", "--out", "--state",
                                  "--redecide", "--case", "--fit-check", "--fold-check", "--worm-check", "--effect", "--reps", "--noise", "--coulomb-scale", "--cutoff", "--files", "--coef",
                                  "--cases"};
  static const char* kFlags[] = {"--no-grid", "--no-base-multistart", "--no-nested-fallback", "--tune-only",
                                 "--score-only", "--single", "--null-check", "--resolution", "--drive-check", "--truth-check", "--noise-check", "--profile-check",
                                 "--null-drive-check", "--simex", "--gap-check"};
  for (int i = 1; i < argc; ++i) {
    auto is = [&](const auto& list) {
      return std::any_of(std::begin(list), std::end(list), [&](const char* n) { return !std::strcmp(argv[i], n); });
    };
    if (is(kFlags)) continue;
    if (is(kValued) && i + 1 < argc) { ++i; continue; }
    std::fprintf(stderr, "diagnose_bench: unknown or incomplete argument '%s' (see --help)\n", argv[i]);
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (Flag(argc, argv, "--help") || Flag(argc, argv, "-h")) { std::fputs(kUsage, stdout); return 0; }
  if (!ArgsKnown(argc, argv)) return 2;
  const double fps = Arg(argc, argv, "--fps", 100), duration = Arg(argc, argv, "--duration", 3);
  Bench b;
  b.argc = argc;
  b.argv = argv;
  b.fps = fps;
  b.duration = duration;
  b.out_path = ArgS(argc, argv, "--out", WORMDRAG_BINARY_DIR "/diagnose_bench/diagnose_bench.jsonl");
  DiagnoseOptions& o = b.o;
  o.t_max = duration;
  o.null_replicates = static_cast<int>(Arg(argc, argv, "--null", 3));
  o.threads = static_cast<int>(Arg(argc, argv, "--threads", 2));
  o.blocks = static_cast<int>(Arg(argc, argv, "--blocks", 6));
  o.grg_iterations = static_cast<int>(Arg(argc, argv, "--iterations", 10));
  o.base_grid = !Flag(argc, argv, "--no-grid");
  o.fit_hz = Arg(argc, argv, "--fit-hz", o.fit_hz);
  o.base_iterations = static_cast<int>(Arg(argc, argv, "--base-iterations", o.base_iterations));
  o.lowpass_hz = Arg(argc, argv, "--lowpass", o.lowpass_hz);
  o.interpolate_gaps = static_cast<int>(Arg(argc, argv, "--interpolate-gaps", o.interpolate_gaps));
  o.substeps = static_cast<int>(Arg(argc, argv, "--substeps", o.substeps));
  o.nested_fallback = !Flag(argc, argv, "--no-nested-fallback");
  o.base_multistart = !Flag(argc, argv, "--no-base-multistart");
  o.cv_ridge = Arg(argc, argv, "--cv-ridge", o.cv_ridge);
  o.refine_top = static_cast<int>(Arg(argc, argv, "--refine-top", o.refine_top));
  o.simex_draws = static_cast<int>(Arg(argc, argv, "--simex-draws", o.simex_draws));
  o.gap_signature_z = Arg(argc, argv, "--gap-signature-z", o.gap_signature_z);
  o.require_estimated_params = Arg(argc, argv, "--require-estimated", o.require_estimated_params ? 1 : 0) != 0;
  o.clear_margin = Arg(argc, argv, "--clear-margin", o.clear_margin);
  auto src_or = LoadSources(Arg(argc, argv, "--kymo-cutoff", 2.5));
  if (!src_or.ok()) { std::fprintf(stderr, "%s\n", src_or.status().ToString().c_str()); return 1; }
  b.src = std::move(*src_or);
  b.src.gap_every_s = Arg(argc, argv, "--gap-every", b.src.gap_every_s);
  // The checks, in the order they take precedence; then one pair, or the seed sets.
  static const struct {
    const char* flag;
    int (*run)(const Bench&);
  } kChecks[] = {{"--truth-check", TruthCheck}, {"--noise-check", NoiseCheck},     {"--profile-check", ProfileCheck},
                 {"--gap-check", GapCheck},     {"--simex", SimexCheck},           {"--resolution", ResolutionCheck},
                 {"--drive-check", DriveCheck}, {"--null-drive-check", NullDriveCheck}, {"--null-check", NullCheck}},
    kSeeded[] = {{"--fit-check", FitCheck}, {"--worm-check", WormCheck}, {"--fold-check", FoldCheck},
                 {"--case", RunOneCase}};
  for (const auto& c : kChecks)
    if (Flag(argc, argv, c.flag)) return c.run(b);
  for (const auto& c : kSeeded)
    if (static_cast<int>(Arg(argc, argv, c.flag, -1)) >= 0) return c.run(b);
  if (Flag(argc, argv, "--single")) return RunSingle(b);
  return RunSets(b);
}
