// replicate_bench's single studies: each answers one question about the noise bias on
// the benchmark pair (see each function's comment; bench/replicate_bench.cc lists them).
#include <cmath>
#include <cstdio>

#include "bench/replicate_setup.h"
#include "core/common/format.h"
#include "core/common/parallel.h"
#include "core/diagnose/synth.h"
#include "core/filter/shape_smoothing.h"
#include "core/jobs/bootstrap_run.h"

namespace wormdrag::bench {

// A fresh noise draw fitted by Phase 3 from the truth, then with its shapes refitted
// (bench/shape_refit.h) with `options`, from Phase 3's fit or from the truth and the
// clean shapes; prints both ratios and each iteration's F on stderr.
void ShapeRefitRow(const Setup& s, int n, const ShapeRefitOptions& options, bool from_truth) {
  std::vector<std::pair<double, double>> out(n, {NAN, NAN});
  ParallelFor(n, 2, [&](int, int64_t draw) {
    const int i = static_cast<int>(draw);
    auto d = Draw(s, s.seed + 100 * (i + 1));
    if (!d.ok()) return;
    const std::array<Kinematics, 2> raw = {(*d)[0].recording, (*d)[1].recording};
    auto smoothed = Smoothed(raw, s.options);
    if (!smoothed.ok()) return;
    // From the truth the refit needs no Phase 3 fit to start from.
    Result<Coefficients> c = s.truth;
    if (!from_truth) {
      auto pair = PairOf(s, *smoothed, false, s.options);
      if (!pair.ok()) return;
      c = Phase3FromTruth(s, *pair);
      if (!c.ok()) return;
    }
    ShapeRefitOptions o = options;
    o.threads = n == 1 ? 2 : 1;
    const std::array<Kinematics, 2> clean = {(*d)[0].clean, (*d)[1].clean};
    o.progress = [&](int it, double f, const Coefficients& x) {
      std::fprintf(stderr, "  draw %d iteration %d: F %.1f, ratio %.4f\n", i, it, f, Ratio(s, x));
    };
    auto r = RefitWithShapes(raw, *smoothed, {TrackingNoiseByDifferences(raw[0]), TrackingNoiseByDifferences(raw[1])},
                             *c, s.options.estimate.eval, o, from_truth ? &clean : nullptr);
    out[i] = {Ratio(s, *c), r.ok() ? Ratio(s, r->set) : NAN};
    std::fprintf(stderr, "draw %d: %.3f -> %.3f  %s\n", i, out[i].first, out[i].second,
                 r.ok() ? r->summary.OneLineReport().c_str() : r.status().ToString().c_str());
  });
  std::printf("| draw | Phase 3 | shapes refitted |\n|---|---|---|\n");
  for (int i = 0; i < n; ++i) std::printf("| %d | %.3f | %.3f |\n", i, out[i].first, out[i].second);
}

// Fresh noise draws at each level of `levels` (% BL), smoothed as the estimator smooths
// and fitted by Phase 3 from the truth: whether the estimate's bias shrinks with the
// noise, as the bootstrap's correction assumes, or jumps to its size at once.
void NoiseLadderRow(Setup s, int n, const std::vector<double>& levels) {
  std::printf("| noise %% BL | fits of fresh draws |\n|---|---|\n");
  for (double level : levels) {
    s.noise_bl = level;
    const std::vector<double> fits = Parallel(n, [&](int i) { return FreshDrawFit(s, i, s.options); });
    char label[32];
    std::snprintf(label, sizeof label, "%g", level);
    PrintRow(label, fits);
    std::fflush(stdout);
  }
}

// Do the data look like their replicates? The pair's own noise draw is fitted by
// Phase 3 from the truth; replicates are made from its smoothed shapes at that fit, with
// its estimated noise, as the bootstrap makes them. The data and each replicate are then
// refitted from that fit with the shape smoothing's λ × 1, ÷ 10 and × 10. Rows: E at the
// refit (mm) and the ratio at each λ: if the data's E or their dependence on λ stood
// out from the replicates', a check could tell when the replicates miss the data's bias.
Status ResemblanceRow(const Setup& s, int n) {
  auto data = Draw(s, s.seed);
  if (!data.ok()) return data.status();
  const std::array<Kinematics, 2> raw = {(*data)[0].recording, (*data)[1].recording};
  auto pair = PairOf(s, raw, true, s.options);
  if (!pair.ok()) return pair.status();
  auto fit = Phase3FromTruth(s, *pair);
  if (!fit.ok()) return fit.status();
  const std::array<double, 2> noise = {TrackingNoiseByDifferences(raw[0]), TrackingNoiseByDifferences(raw[1])};
  const double scales[3] = {1, 0.1, 10};
  // Job 3 r + k: replicate r (r = 0: the data) with λ × scales[k]; E from k = 0.
  std::vector<double> ratio(3 * (n + 1), NAN), e(n + 1, NAN);
  ParallelFor(3 * (n + 1), 2, [&](int, int64_t job) {
    const int r = static_cast<int>(job / 3), k = static_cast<int>(job % 3);
    JobOptions o = s.options;
    o.spline.lambda_scale = scales[k];
    Result<ScoredSet> f = Status::Internal("");
    if (r == 0) {
      auto p = PairOf(s, raw, true, o);
      if (!p.ok()) return;
      f = FitReplicate(**p, {0, {*fit, 0}, std::nullopt, {0, 0}, true, scales[k]}, o);
    } else {
      f = FitReplicate(**pair, {r - 1, {*fit, 0}, std::nullopt, noise}, o);
    }
    if (!f.ok()) return;
    ratio[job] = Ratio(s, f->set);
    if (k == 0) e[r] = f->e;
  });
  std::printf("fit from the truth: %.3f\n\n| refits of | E mm | λ × 1 | ÷ 10 | × 10 |\n|---|---|---|---|---|\n",
              Ratio(s, *fit));
  for (int r = 0; r <= n; ++r)
    std::printf("| %s %d | %.5f | %.3f | %.3f | %.3f |\n", r ? "replicate" : "the data", r ? r - 1 : 0, e[r],
                ratio[3 * r], ratio[3 * r + 1], ratio[3 * r + 2]);
  return Status::Ok();
}

// SIMEX (simulation–extrapolation): each fresh noise draw is fitted as it is, then with
// tracking noise added so that its variance is 2 and 3 times the data's (σ̂ estimated
// from the draw, as the estimator does), each smoothed as the estimator smooths and fitted
// by Phase 3 from the truth; the fits are extrapolated back to no noise, linearly from
// variance 1 and 2 and quadratically from 1, 2 and 3.
void SimexRow(const Setup& s, int n, int copies) {
  std::printf("| draw | fit | noise variance x2 | x3 | linear to 0 | quadratic to 0 |\n|---|---|---|---|---|---|\n");
  for (int i = 0; i < n; ++i) {
    auto d = Draw(s, s.seed + 100 * (i + 1));
    if (!d.ok()) continue;
    const std::array<Kinematics, 2> raw = {(*d)[0].recording, (*d)[1].recording};
    const double sigma = 0.5 * (TrackingNoiseByDifferences(raw[0]) + TrackingNoiseByDifferences(raw[1]));
    // Job 0: the draw itself; then `copies` copies at each added variance.
    std::vector<double> fits(1 + 2 * copies, NAN);
    ParallelFor(1 + 2 * copies, 2, [&](int, int64_t job) {
      std::array<Kinematics, 2> k = raw;
      if (job > 0) {
        const double extra = job <= copies ? 1 : 2;  // added variance in units of σ̂²
        for (int w = 0; w < 2; ++w)
          diagnose::AddTrackingNoise(&k[w], sigma * std::sqrt(extra), 7919 * job + w + 31 * i);
      }
      auto p = PairOf(s, k, true, s.options);
      if (p.ok()) fits[job] = FitFromTruth(s, *p);
    });
    double k1 = 0, k2 = 0;
    for (int c = 0; c < copies; ++c) k1 += fits[1 + c] / copies, k2 += fits[1 + copies + c] / copies;
    const double k0 = fits[0];
    std::printf("| %d | %.3f | %.3f | %.3f | %.3f | %.3f |\n", i, k0, k1, k2, 2 * k0 - k1, 3 * k0 - 3 * k1 + k2);
    std::fflush(stdout);
  }
}

// Replicates made at the truth from the data low-passed at each cut-off, beside fresh
// noise draws of the data (the estimator's answer). 0 on success.
int LowpassTruthRows(const Setup& s, int n, const std::vector<double>& cutoffs) {
  auto data = Draw(s, s.seed);
  if (!data.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", data.status().ToString().c_str()), 1;
  const std::array<Kinematics, 2> raw = {(*data)[0].recording, (*data)[1].recording};
  std::printf("| refits of | values, sorted |\n|---|---|\n");
  PrintRow("fresh noise draws of the data", Parallel(n, [&](int i) { return FreshDrawFit(s, i, s.options); }));
  for (double hz : cutoffs) {
    JobOptions lowpass = s.options;
    lowpass.smoothing = SmoothingMethod::kLowpass;
    lowpass.lowpass_hz = hz;
    auto from = PairOf(s, raw, true, lowpass);
    if (!from.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", from.status().ToString().c_str()), 1;
    const std::string label = "replicates from the data low-passed at " + FormatNumber(hz, 3) + " Hz";
    PrintRow(label.c_str(), Parallel(n, [&](int i) { return TruthReplicateFit(s, **from, i); }));
  }
  return 0;
}

}  // namespace wormdrag::bench
