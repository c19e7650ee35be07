// The benchmark's default mode: diagnose the pairs of a tuning seed set and a scoring
// seed set (or re-read them from a saved state, --redecide), tune the decision rules on
// the first, and score the second once with them.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <mutex>

#include "bench/diagnose/bench.h"
#include "core/common/parallel.h"

namespace wormdrag::diagnose_bench {
namespace {

// Outcomes saved by an earlier run (a --state file), sorted into the tuning and the
// scoring set by their "set" field. Returns an exit code (0: read).
int LoadState(const std::string& path, std::vector<Outcome>* tune, std::vector<Outcome>* score) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", path.c_str());
    return 1;
  }
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded()) {
      std::fprintf(stderr, "%s: a line is not JSON\n", path.c_str());
      return 1;
    }
    Outcome x;
    bool known = false;
    try {
      known = OutcomeOf(j, &x);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: a line is not a benchmark outcome (%s)\n", path.c_str(), e.what());
      return 1;
    }
    if (!known) {
      std::fprintf(stderr, "%s: a line names no benchmark case\n", path.c_str());
      return 1;
    }
    (j["set"] == "score" ? *score : *tune).push_back(std::move(x));
  }
  return 0;
}

// Diagnoses the pairs of the tuning set (set 0) or the scoring set (set 1), `--jobs` at a
// time (each diagnosis on o.threads threads), writing each outcome to the summary file
// and the state as it finishes.
void RunSet(const Bench& b, int set, std::chrono::steady_clock::time_point t0, FILE* f, std::ofstream* state,
            std::vector<Outcome>* out) {
  auto cases = MakeCases(
      static_cast<uint64_t>(Arg(b.args, set == 0 ? "--tune-seed" : "--score-seed", set == 0 ? 11 : 23)));
  const int tune_limit = static_cast<int>(Arg(b.args, "--tune-limit", 1e9));
  if (set == 0 && static_cast<int>(cases.size()) > tune_limit) {
    // An evenly spread subset of the tuning cases (every category stays represented).
    std::vector<Case> sub;
    for (int i = 0; i < tune_limit; ++i) sub.push_back(cases[i * cases.size() / tune_limit]);
    cases = sub;
  }
  // Cases run `--jobs` at a time (each diagnosis on o.threads threads).
  std::vector<Outcome> results(cases.size());
  std::atomic<int> done{0};
  std::mutex mu;
  const int jobs = std::max(1, static_cast<int>(Arg(b.args, "--jobs", 1)));
  ParallelFor(static_cast<int64_t>(cases.size()), jobs, [&](int, int64_t i) {
    const Case& c = cases[i];
    Outcome x = RunCase(c, b.src, b.o, b.fps, b.duration);
    std::lock_guard<std::mutex> lock(mu);
    std::fprintf(stderr, "[%s %d/%zu %.0fs] #%d %s/%d -> %s (%s)\n", set ? "score" : "tune", ++done, cases.size(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), static_cast<int>(i),
                 c.effect.c_str(), c.strength, x.ok ? x.d.verdict.c_str() : "ERROR", x.error.c_str());
    if (f) {
      const wormdrag::Json line = {{"set", set ? "score" : "tune"}, {"case", SummaryJson(x)}};
      std::fprintf(f, "%s\n", Dump(line).c_str());
      std::fflush(f);
    }
    if (*state) *state << StateOf(set ? "score" : "tune", x).dump() << std::endl;
    results[i] = std::move(x);
  });
  for (auto& x : results) out->push_back(std::move(x));
}

// The decision rules tuned on `tune`: score_refined_fit (off/on) and simex_weight by
// grid search on the benchmark's objective (simex_min_keep and the other thresholds stay
// at their defaults, the noise tests at --false-alarm-rate; docs/decisions/0015-effect-bar.md,
// 0039). Ties go to the earlier grid point (off, then the smaller value). A flag
// (--simex-weight W, ...) fixes that value. Without tuning pairs the defaults stand.
DiagnoseOptions Tune(const Bench& b, std::vector<Outcome>& tune) {
  const DiagnoseOptions& o = b.o;
  const flags::Args& args = b.args;
  DiagnoseOptions best = o;
  double best_obj = -1e9;
  auto grid = [&](const char* flag, std::vector<double> values) {
    const double v = Arg(args, flag, -1);
    return v >= 0 ? std::vector<double>{v} : values;
  };
  const std::vector<double> own = grid("--score-refined-fit", {0, 1});
  const std::vector<double> weights = grid("--simex-weight", {0.0, 1.0, 2.0, 4.0});
  const std::vector<double> keeps = grid("--simex-min-keep", {o.simex_min_keep});
  if (tune.empty()) return best;
  std::vector<std::pair<double, std::string>> tried;
  for (double so : own)
    for (double w : weights)
      for (double k : keeps) {
        DiagnoseOptions t = o;
        t.score_refined_fit = so > 0;
        t.simex_weight = w;
        t.simex_min_keep = k;
        const Score s = Evaluate(tune, t);
        char line[160];
        std::snprintf(line, sizeof line, "own %g, weight %g, keep %g", so, w, k);
        tried.emplace_back(s.objective, line);
        if (s.objective > best_obj + 1e-12) {
          best_obj = s.objective;
          best = t;
        }
      }
  std::stable_sort(tried.begin(), tried.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  std::printf("tuning objective, %zu grid points; the best (ties in grid order):\n", tried.size());
  for (size_t i = 0; i < std::min<size_t>(12, tried.size()); ++i)
    std::printf("  %.3f  %s\n", tried[i].first, tried[i].second.c_str());
  return best;
}

}  // namespace

int RunSets(const Bench& b) {
  const flags::Args& args = b.args;
  std::vector<Outcome> tune, score;
  const std::string redecide = ArgS(args, "--redecide", "");
  if (!redecide.empty()) {
    if (const int rc = LoadState(redecide, &tune, &score)) return rc;
  } else {
    CreateParentFolder(b.out_path);
    FILE* f = std::fopen(b.out_path.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", b.out_path.c_str());
      return 1;
    }
    const std::string state_path = ArgS(args, "--state", b.out_path + ".state");
    CreateParentFolder(state_path);
    std::ofstream state(state_path);
    const auto t0 = std::chrono::steady_clock::now();
    // --tune-only: the tuning set only; --score-only: the scoring set only (its state is then
    // re-scored with --redecide together with the tuning run's, so that a variant chosen
    // on the tuning set is scored once).
    const int nsets = Flag(args, "--tune-only") ? 1 : 2;
    for (int set = Flag(args, "--score-only") ? 1 : 0; set < nsets; ++set)
      RunSet(b, set, t0, f, &state, set ? &score : &tune);
    std::fclose(f);
  }
  const DiagnoseOptions best = Tune(b, tune);
  const Score st = Evaluate(tune, best), ss = Evaluate(score, best);
  std::printf(
      "%s thresholds: false_alarm_rate %g, min_improvement %g, explained_share %g, "
      "tie_fraction %g, require_shrink_interval %d, "
      "simex_weight %g, simex_min_keep %g, score_refined_fit %d, require_gap_signature %d, "
      "require_estimated_params %d, clear_margin %g\n",
      tune.empty() ? "default (no tuning pairs)" : "tuned", best.false_alarm_rate, best.min_improvement,
      best.explained_share, best.tie_fraction, best.require_shrink_interval ? 1 : 0, best.simex_weight,
      best.simex_min_keep, best.score_refined_fit ? 1 : 0, best.require_gap_signature ? 1 : 0,
      best.require_estimated_params ? 1 : 0, best.clear_margin);
  if (!tune.empty()) PrintSet("tuning", tune, st, best);
  if (!score.empty()) PrintSet("SCORING (fresh seeds, scored once)", score, ss, best);
  return 0;
}

}  // namespace wormdrag::diagnose_bench
