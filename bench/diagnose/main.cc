// The diagnosis benchmark's entry point: builds the options every mode shares from the
// command line and runs the mode asked for (one file per check under bench/diagnose/).
#include <cstdio>

#include "bench/diagnose/bench.h"

using namespace wormdrag::diagnose_bench;
namespace flags = wormdrag::flags;

namespace {

constexpr const char* kModes = R"(Benchmark of the sim-to-real gap diagnosis (docs/diagnose.md, "Benchmark"). Modes:

  diagnose_bench [options]            tune on seed set --tune-seed, score seed set --score-seed
  diagnose_bench --tune-only | --score-only [options]    one of the two sets
  diagnose_bench --redecide STATE     re-tune and re-score saved outcomes (no fits)
  diagnose_bench --single             time one diagnosis (2 x 5 s at 300 fps by default)
  diagnose_bench --case SEED          one benchmark case (SEED = set x 1000 + index); --state PATH appends its outcome
  diagnose_bench --fit-check SEED     base fits from the truth and from the start(s)
  diagnose_bench --fold-check SEED    the CV's base fold fits from its start, the truth and the leading effects' fits
  diagnose_bench --worm-check SEED [--effect NAME]   an effect (time_drift) fitted with one parameter for both worms
                 and with one per worm, on all blocks and on each half
  diagnose_bench --null-truth-check [--set N[,N...]] [--truths LIST] [--qq FILE.svg]   the gap test's p-values on none pairs with the
                 replicates' truth made in several ways
  diagnose_bench --null-check | --resolution | --drive-check | --null-drive-check | --truth-check    measurements (docs/diagnose.md)
  diagnose_bench --strength-check [--set N]   how far each effect of seed set N moves its noise-free pair
  diagnose_bench --noise-check [--effect NAME]   the true model of NAME [stiction] on its pairs and the none pairs of
                 --score-seed: held-out E at 0, 0.2 and 2 um of noise, noise-free with 4x the knots, and noise-free
                 on the continuous path (no pose restarts)
  diagnose_bench --profile-check [--effect NAME]   held-out E of NAME's [stiction] model along its parameter (the
                 true coefficients, 2 um of noise) on its pairs of --score-seed: is it smooth enough for the GRG?
  diagnose_bench --gap-check (--case SEED | --files K1.csv,K2.csv) [--coef MU_N,MU_T,ETA_N,ETA_T]   gap_offset's mark
                 in the residual of a base fit (a case's default: its truth's coefficients): one line
  diagnose_bench --simex (--files K1.csv,K2.csv --coef MU_N,MU_T,ETA_N,ETA_T | --case SEED) --noise SIGMA [--reps N]
                 gap_offset on a recorded pair with added noise (simulation-extrapolation))";

flags::Spec BenchSpec() {
  return {"diagnose_bench",
          "[mode] [options]",
          kModes,
          {
              // Modes.
              {"tune-only", "", "tune only (seed set --tune-seed)", ""},
              {"score-only", "", "score only (seed set --score-seed)", ""},
              {"redecide", "STATE", "re-tune and re-score saved outcomes (no fits)", ""},
              {"single", "", "time one diagnosis (--fps 300 --duration 5 unless given)", ""},
              {"case", "SEED", "one benchmark case (SEED = set x 1000 + index)", ""},
              {"fit-check", "SEED", "base fits from the truth and from the start(s)", ""},
              {"fold-check", "SEED", "the CV's base fold fits", ""},
              {"worm-check", "SEED", "an effect fitted with one parameter for both worms and one per worm", ""},
              {"null-check", "", "measurement (docs/diagnose.md)", ""},
              {"null-truth-check", "", "measurement (docs/diagnose.md)", ""},
              {"truths", "LIST",
               "--null-truth-check: the replicates' truths (data, data*K, clean, shapes, poses, periodic, gait)",
               "data,clean"},
              {"qq", "FILE.svg", "--null-truth-check: write the full-path p-values' QQ plot", ""},
              {"resolution", "", "measurement (docs/diagnose.md)", ""},
              {"drive-check", "", "measurement (docs/diagnose.md)", ""},
              {"null-drive-check", "", "measurement (docs/diagnose.md)", ""},
              {"truth-check", "", "measurement (docs/diagnose.md)", ""},
              {"strength-check", "", "how far each effect moves its noise-free pair", ""},
              {"noise-check", "", "the true model of --effect on its pairs at several noise levels", ""},
              {"profile-check", "", "held-out E of --effect's model along its parameter", ""},
              {"gap-check", "", "gap_offset's mark in the residual of a base fit", ""},
              {"simex", "", "gap_offset on a recorded pair with added noise", ""},
              // What every mode shares.
              {"fps", "F", "frame rate of the pairs", "100"},
              {"duration", "S", "length of the pairs", "3"},
              {"null", "R", "noise-only replicates", "3"},
              {"threads", "N", "threads", "2"},
              {"jobs", "J", "cases diagnosed at once", "1"},
              {"blocks", "B", "CV blocks", "6"},
              {"iterations", "N", "GRG iterations", "10"},
              {"base-iterations", "N", "GRG iterations of the base fit", "150"},
              {"no-grid", "", "no base grid", ""},
              {"fit-hz", "H", "fit rate", "30"},
              {"substeps", "N", "simulation substeps", "2"},
              {"smoothing", "METHOD", "auto, lowpass or none (DiagnoseOptions::smoothing)", "auto"},
              {"lowpass", "HZ", "joint-angle low-pass for --smoothing lowpass", "5"},
              {"kymo-cutoff", "HZ", "low-pass of the kymogram sources", "2.5"},
              {"interpolate-gaps", "N", "gaps up to N frames interpolated", "0"},
              {"gap-every", "S", "period of the pairs' dropped-frame runs", "0.25"},
              {"cv-ridge", "W", "CV ridge weight", "0.5"},
              {"refine-top", "N", "effects refined", "1"},
              {"no-base-multistart", "", "one start of the base fit", ""},
              {"no-nested-fallback", "", "no nested fallback", ""},
              {"tune-seed", "N", "seed set tuned on", "11"},
              {"score-seed", "N", "seed set scored (and of the checks)", "23"},
              {"tune-limit", "N", "at most N tuning cases", ""},
              {"simex-draws", "N", "SIMEX draws", "3"},
              {"simex-weight", "W", "SIMEX weight", "tuned"},
              {"simex-min-keep", "K", "SIMEX least fraction kept", "0.3"},
              {"no-gap-signature", "", "name gap_offset without its mark in the residual", ""},
              {"require-estimated", "0|1", "require estimated parameters", "1"},
              {"clear-margin", "M", "margin of a clear verdict", "2"},
              {"score-refined-fit", "0|1", "score the refined fit", "tuned"},
              {"false-alarm-rate", "A", "false-alarm rate of the verdict's tests", "0.05"},
              {"min-improvement", "G", "least relative gain of a named effect", "0.12"},
              {"out", "FILE", "summary lines", "build/diagnose_bench/diagnose_bench.jsonl"},
              {"state", "PATH", "saved outcomes", "FILE.state"},
              // What some modes read.
              {"effect", "NAME", "--worm-check: time_drift; --noise-check, --profile-check: stiction", ""},
              {"files", "K1.csv,K2.csv", "--gap-check, --simex: a recorded pair", ""},
              {"coef", "MU_N,MU_T,ETA_N,ETA_T", "--gap-check, --simex: the pair's coefficients", ""},
              {"noise", "MM",
               "--case, --null-check, --null-drive-check: tracking noise (default 0.002);\n"
               "--drive-check: 0.0002, besides 0.002",
               ""},
              {"reps", "N", "--null-check: replicates (default 3); --null-drive-check: 2; --simex: draws", ""},
              {"set", "N",
               "--null-check, --null-truth-check (N,N...): the sets whose none pairs are used; --strength-check", "11"},
              {"coulomb-scale", "K", "--null-check, --drive-check", "1"},
              {"cutoff", "HZ", "--drive-check", "5 and 3"},
              {"cases", "N", "--resolution", "6"},
          },
          false};
}

}  // namespace

int main(int argc, char** argv) {
  Bench b;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), BenchSpec(), &b.args)) return *rc;
  const flags::Args& args = b.args;
  const double fps = Arg(args, "--fps", 100), duration = Arg(args, "--duration", 3);
  b.fps = fps;
  b.duration = duration;
  b.out_path = ArgS(args, "--out", WORMDRAG_BINARY_DIR "/diagnose_bench/diagnose_bench.jsonl");
  DiagnoseOptions& o = b.o;
  o.t_max = duration;
  o.null_replicates = static_cast<int>(Arg(args, "--null", 3));
  o.threads = static_cast<int>(Arg(args, "--threads", 2));
  o.blocks = static_cast<int>(Arg(args, "--blocks", 6));
  o.grg_iterations = static_cast<int>(Arg(args, "--iterations", 10));
  o.base_grid = !Flag(args, "--no-grid");
  o.fit_hz = Arg(args, "--fit-hz", o.fit_hz);
  o.base_iterations = static_cast<int>(Arg(args, "--base-iterations", o.base_iterations));
  o.lowpass_hz = Arg(args, "--lowpass", o.lowpass_hz);
  if (auto m = wormdrag::ParseSmoothingMethod(ArgS(args, "--smoothing", wormdrag::SmoothingMethodName(o.smoothing)));
      m.ok()) {
    o.smoothing = *m;
  } else {
    std::fprintf(stderr, "diagnose_bench: --smoothing: %s\n", m.status().message().c_str());
    return 2;
  }
  o.interpolate_gaps = static_cast<int>(Arg(args, "--interpolate-gaps", o.interpolate_gaps));
  o.substeps = static_cast<int>(Arg(args, "--substeps", o.substeps));
  o.nested_fallback = !Flag(args, "--no-nested-fallback");
  o.base_multistart = !Flag(args, "--no-base-multistart");
  o.cv_ridge = Arg(args, "--cv-ridge", o.cv_ridge);
  o.refine_top = static_cast<int>(Arg(args, "--refine-top", o.refine_top));
  o.simex_draws = static_cast<int>(Arg(args, "--simex-draws", o.simex_draws));
  o.require_gap_signature = !Flag(args, "--no-gap-signature");
  o.require_estimated_params = Arg(args, "--require-estimated", o.require_estimated_params ? 1 : 0) != 0;
  o.clear_margin = Arg(args, "--clear-margin", o.clear_margin);
  o.false_alarm_rate = Arg(args, "--false-alarm-rate", o.false_alarm_rate);
  o.min_improvement = Arg(args, "--min-improvement", o.min_improvement);
  auto src_or = LoadSources(Arg(args, "--kymo-cutoff", 2.5));
  if (!src_or.ok()) {
    std::fprintf(stderr, "%s\n", src_or.status().ToString().c_str());
    return 1;
  }
  b.src = std::move(*src_or);
  b.src.gap_every_s = Arg(args, "--gap-every", b.src.gap_every_s);
  // The checks, in the order they take precedence; then one pair, or the seed sets.
  static const struct {
    const char* flag;
    int (*run)(const Bench&);
  } kChecks[] = {{"--truth-check", TruthCheck},
                 {"--noise-check", NoiseCheck},
                 {"--profile-check", ProfileCheck},
                 {"--gap-check", GapCheck},
                 {"--simex", SimexCheck},
                 {"--resolution", ResolutionCheck},
                 {"--drive-check", DriveCheck},
                 {"--null-drive-check", NullDriveCheck},
                 {"--null-check", NullCheck},
                 {"--null-truth-check", NullTruthCheck},
                 {"--strength-check", StrengthCheck}},
    kSeeded[] = {
        {"--fit-check", FitCheck}, {"--worm-check", WormCheck}, {"--fold-check", FoldCheck}, {"--case", RunOneCase}};
  for (const auto& c : kChecks)
    if (Flag(args, c.flag)) return c.run(b);
  for (const auto& c : kSeeded)
    if (static_cast<int>(Arg(args, c.flag, -1)) >= 0) return c.run(b);
  if (Flag(args, "--single")) return RunSingle(b);
  return RunSets(b);
}
