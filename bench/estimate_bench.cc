// Estimation benchmark: the full default pipeline on one verification pair
// (2 × 5 s at 300 fps), then Phase 3 by every method from the same Phase 2 survivors.
// Prints Markdown tables for BENCHMARKS.md.
//   build/bench/estimate_bench [--set N] [--threads T] [--methods grg,slsqp,…]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "core/common/flags.h"
#include "core/estimate/estimator.h"
#include "core/sim/pattern.h"

using namespace wormdrag;

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double PctErr(double est, double truth) {
  return 100.0 * std::abs(est - truth) / truth;
}

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{"estimate_bench",
                         "[--set N] [--threads T] [--methods grg,slsqp,…] [--scale-decades D]",
                         "The full default pipeline on one verification pair (2 x 5 s at 300 fps), then\n"
                         "Phase 3 by every method from the same Phase 2 survivors (BENCHMARKS.md).",
                         {{"set", "N", "verification set F1…F10", "1"},
                          {"threads", "T", "worker threads", "all cores"},
                          {"methods", "LIST", "Phase 3 methods to compare", "grg,slsqp,lbfgs,bobyqa,neldermead"},
                          {"scale-decades", "D", "Phase 3's scale search, decades", "the estimator's"}},
                         false};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const int set = std::atoi(args.Get("set", "1").c_str());
  const int threads = args.Has("threads") ? std::atoi(args.Get("threads").c_str()) : DefaultThreads();
  const std::string methods = args.Get("methods", "grg,slsqp,lbfgs,bobyqa,neldermead");
  const double scale_decades = args.Has("scale-decades") ? std::atof(args.Get("scale-decades").c_str())
                                                         : EstimateOptions().phase3.scale_search_decades;
  // F1…F10 exactly as `wormdrag verify` draws them (seed 2017).
  std::mt19937_64 rng(2017);
  std::uniform_real_distribution<double> mu(0.0, 1.0), eta(0.0, 0.01);
  Coefficients truth;
  for (int i = 1; i <= set; ++i) truth = {mu(rng), mu(rng), eta(rng), eta(rng)};
  EstimateOptions eo;
  eo.phase3.scale_search_decades = scale_decades;
  const int la = set <= 5 ? 1 : 3;
  std::array<Kinematics, 2> rec;
  for (int w = 0; w < 2; ++w) {
    RecordingSpec spec;
    spec.substeps = eo.eval.SubstepsFor(spec.fps);
    spec.as_estimated = true;
    rec[w] = *GenerateRecording(Locomotion(la + w), truth, eo.eval.sim, spec);
  }
  auto accurate = *PairedPath::Create(rec, {"a", "b"}, eo.eval);
  auto screening = *PairedPath::Create(rec, {"a", "b"}, eo.ScreeningEval());
  LocalEvaluator fast(screening, threads), acc(accurate, threads);

  std::printf("F%d = (%.4f, %.4f, %.5f, %.5f), %d threads\n\n", set, truth.mu_n, truth.mu_t, truth.eta_n, truth.eta_t,
              threads);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = RunEstimate(fast, acc, eo, accurate->mean_body_length());
  const double total = Seconds(t0);
  if (!r.ok()) {
    std::fprintf(stderr, "%s\n", r.status().ToString().c_str());
    return 1;
  }
  std::printf("| stage | sets | wall s |\n|---|---|---|\n");
  for (const PhaseSummary* p : {&r->phase1, &r->phase2, &r->phase3})
    std::printf("| %s | %lld | %.1f |\n", p->name.c_str(), static_cast<long long>(p->sets), p->seconds);
  std::printf("| whole pipeline incl. identifiability | | **%.1f** |\n\n", total);

  std::printf(
      "| Phase 3 method | final E mm | E %% BL | evaluations | wall s | K_mu err %% | K_eta err %% | v_c err %% |\n"
      "|---|---|---|---|---|---|---|---|\n");
  size_t pos = 0;
  while (pos <= methods.size()) {
    const size_t c = std::min(methods.find(',', pos), methods.size());
    auto m = ParsePhase3Method(methods.substr(pos, c - pos));
    pos = c + 1;
    if (!m.ok()) continue;
    Phase3Options o = eo.phase3;
    o.method = *m;
    PhaseSummary s;
    const auto t1 = std::chrono::steady_clock::now();
    auto best = RunPhase3(r->survivors2, eo.search, o, acc, &s);
    const double dt = Seconds(t1);
    if (!best.ok()) {
      std::printf("| %s | failed: %s |\n", Phase3MethodName(*m), best.status().message().c_str());
      continue;
    }
    const Coefficients& b = best->set;
    std::printf("| %s | %.3g | %.3g | %lld | %.1f | %.3g | %.3g | %.3g |\n", Phase3MethodName(*m), best->e,
                100 * best->e / accurate->mean_body_length(), static_cast<long long>(s.sets), dt,
                PctErr(b.K_mu(), truth.K_mu()), PctErr(b.K_eta(), truth.K_eta()), PctErr(b.v_c(), truth.v_c()));
    std::fflush(stdout);
  }
  return 0;
}
