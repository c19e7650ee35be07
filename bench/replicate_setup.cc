#include "bench/replicate_setup.h"

#include <algorithm>
#include <cmath>

#include "bench/noise_pairs.h"
#include "core/common/parallel.h"
#include "core/jobs/bootstrap_run.h"

namespace wormdrag::bench {

double Ratio(const Setup& s, const Coefficients& c) {
  return s.regime == "agar" ? c.K_mu() : c.K_eta();
}

Result<std::array<diagnose::SynthOutput, 2>> Draw(const Setup& s, int noise_seed) {
  return SynthesizePair(s.truth, s.drive, s.noise_bl, s.seed, noise_seed, 300, 5, &s.real);
}

Result<std::array<Kinematics, 2>> Smoothed(const std::array<Kinematics, 2>& k, const JobOptions& options) {
  std::array<Kinematics, 2> out;
  for (int w = 0; w < 2; ++w) {
    auto r = SmoothRecording("worm " + std::to_string(w + 1), k[w], options);
    if (!r.ok()) return r.status();
    out[w] = std::move(*r);
  }
  return out;
}

Result<std::shared_ptr<const PairedPath>> PairOf(const Setup& s, const std::array<Kinematics, 2>& k, bool smooth,
                                                 const JobOptions& options) {
  if (!smooth) return PairedPath::Create(k, {"w1", "w2"}, s.options.estimate.eval);
  auto out = Smoothed(k, options);
  if (!out.ok()) return out.status();
  return PairedPath::Create(*out, {"w1", "w2"}, s.options.estimate.eval);
}

Result<Coefficients> Phase3FromTruth(const Setup& s, std::shared_ptr<const PairedPath> pair) {
  LocalEvaluator ev(std::move(pair), 1);
  PhaseSummary summary;
  auto f = RunPhase3({{s.truth, 0}}, s.options.estimate.search, s.options.estimate.phase3, ev, &summary);
  if (!f.ok()) return f.status();
  return f->set;
}

double FitFromTruth(const Setup& s, std::shared_ptr<const PairedPath> pair) {
  auto c = Phase3FromTruth(s, std::move(pair));
  return c.ok() ? Ratio(s, *c) : NAN;
}

double FreshDrawFit(const Setup& s, int i, const JobOptions& options) {
  auto d = Draw(s, s.seed + 100 * (i + 1));
  if (!d.ok()) return NAN;
  auto p = PairOf(s, {(*d)[0].recording, (*d)[1].recording}, true, options);
  return p.ok() ? FitFromTruth(s, *p) : NAN;
}

double TruthReplicateFit(const Setup& s, const PairedPath& from, int i) {
  ReplicateTask t{i, {s.truth, 0}, s.truth, {0.005, 0.005}};
  auto f = FitReplicate(from, t, s.options);
  return f.ok() ? Ratio(s, f->set) : NAN;
}

void PrintRow(const char* label, const std::vector<double>& v) {
  std::printf("| %s |", label);
  for (double x : v) std::printf(" %.3f", x);
  std::printf(" |\n");
}

std::vector<double> Parallel(int n, const std::function<double(int)>& job) {
  std::vector<double> out(n, NAN);
  ParallelFor(n, 2, [&](int, int64_t i) { out[i] = job(static_cast<int>(i)); });
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace wormdrag::bench
