// Do bootstrap replicates behave like the data? (docs/estimation.md, "Intervals";
// decision record 0031). On one benchmark pair (noise_bench's regimes and drives) it
// refits, each by Phase 3 from the truth:
//
//   data      fresh noise draws of the pair, smoothed as the estimator does: how the
//             estimator's answer really scatters around the truth;
//   smoothed  replicates made at the truth from the smoothed data (what the
//             bootstrap does);
//   clean     replicates made at the truth from the clean shapes (what it would do
//             if it knew the shapes);
//   raw       replicates made at the truth from the unsmoothed data, whose shapes keep
//             the detail with its timing, and the noise;
//   detail    replicates made at the truth from the smoothed shapes plus, in the
//             shape modes that carry shape, the detail the smoothing took from the
//             clean shapes (clean − smoothed) as it is, or with its Fourier phases
//             randomised: whether the data's bias comes from that detail, and from
//             its spectrum alone or from its timing;
//   lambda    the data themselves with the shape smoothing's λ ÷ and × 10 (the
//             smoothing check), and GCV's spread of log₁₀ λ per shape mode over the
//             noise draws.
//
// With --lowpass-truths HZ,… it does only this: replicates made at the truth from the
// data low-passed at each cut-off (the paper's Butterworth), smoothed and refitted as
// the estimator does, beside the fresh noise draws — whether replicates whose shapes
// keep less of the data's own noise carry the data's bias.
//
// With --shape-refit it does only this: fresh noise draws fitted by Phase 3 and then
// with their shapes refitted with the friction (bench/shape_refit.h, errors in
// variables), optionally from the truth and the clean shapes. --simex, --resemblance
// and --noise-ladder are single studies of their own (see each one's function).
//
//   replicate_bench [--regime agar|water] [--drive real|pattern] [--seed 2] [--draws 6]
//                   [--draw-lambda-scale 1] [--shape-refit [--shape-refit-iterations 12]
//                   [--shape-refit-roughness 1] [--shape-refit-knots 20] [--shape-refit-from-truth]]
//                   [--simex] [--resemblance] [--noise-ladder 0,0.05,0.2,0.5] [--all-points]
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "bench/noise_pairs.h"
#include "bench/shape_refit.h"
#include "core/common/flags.h"
#include "core/common/format.h"
#include "core/common/parallel.h"
#include "core/filter/shape_modes.h"
#include "core/filter/shape_smoothing.h"
#include "core/filter/smoothing_spline.h"
#include "core/jobs/bootstrap_run.h"
#include "core/jobs/estimate_job.h"
#include "core/model/body.h"

using namespace wormdrag;

namespace {

struct Setup {
  std::string regime, drive;
  int seed = 2;
  double noise_bl = 0.5;  // tracking noise, % BL
  Coefficients truth;
  Kinematics real;
  JobOptions options;
};

double Ratio(const Setup& s, const Coefficients& c) {
  return s.regime == "agar" ? c.K_mu() : c.K_eta();
}

// One noisy recording pair of the benchmark with its own noise seed, raw and clean.
Result<std::array<diagnose::SynthOutput, 2>> Draw(const Setup& s, int noise_seed) {
  return bench::SynthesizePair(s.truth, s.drive, s.noise_bl, s.seed, noise_seed, 300, 5, &s.real);
}

// Both recordings smoothed with `options`, as the estimator smooths them.
Result<std::array<Kinematics, 2>> Smoothed(const std::array<Kinematics, 2>& k, const JobOptions& options) {
  std::array<Kinematics, 2> out;
  for (int w = 0; w < 2; ++w) {
    auto r = SmoothRecording("worm " + std::to_string(w + 1), k[w], options);
    if (!r.ok()) return r.status();
    out[w] = std::move(*r);
  }
  return out;
}

// The pair of two recordings, each smoothed with `options` (or left as they are).
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

// Fresh noise draw `i` of the pair, smoothed with `options` and fitted by Phase 3 from
// the truth: how the estimator's answer scatters around the truth.
double FreshDrawFit(const Setup& s, int i, const JobOptions& options) {
  auto d = Draw(s, s.seed + 100 * (i + 1));
  if (!d.ok()) return NAN;
  auto p = PairOf(s, {(*d)[0].recording, (*d)[1].recording}, true, options);
  return p.ok() ? FitFromTruth(s, *p) : NAN;
}

// Replicate `i` made at the truth from the shapes of `from` (5 µm of noise), smoothed and
// refitted as the bootstrap refits it.
double TruthReplicateFit(const Setup& s, const PairedPath& from, int i) {
  ReplicateTask t{i, {s.truth, 0}, s.truth, {0.005, 0.005}};
  auto f = FitReplicate(from, t, s.options);
  return f.ok() ? Ratio(s, f->set) : NAN;
}

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

void PrintRow(const char* label, const std::vector<double>& v) {
  std::printf("| %s |", label);
  for (double x : v) std::printf(" %.3f", x);
  std::printf(" |\n");
}

// Runs `n` jobs on both cores; job(i) returns one value.
std::vector<double> Parallel(int n, const std::function<double(int)>& job) {
  std::vector<double> out(n, NAN);
  ParallelFor(n, 2, [&](int, int64_t i) { out[i] = job(static_cast<int>(i)); });
  std::sort(out.begin(), out.end());
  return out;
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

// A random-phase copy of x: the same amplitude spectrum (plain DFT; a few thousand
// samples), independent phases.
std::vector<double> RandomPhases(const std::vector<double>& x, std::mt19937_64& rng) {
  const int n = static_cast<int>(x.size());
  std::vector<std::complex<double>> y(n);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  for (int k = 0; 2 * k <= n; ++k) {
    std::complex<double> s = 0;
    for (int t = 0; t < n; ++t) s += x[t] * std::polar(1.0, -2 * M_PI * double(k) * t / n);
    y[k] = k == 0 || 2 * k == n ? s : std::polar(std::abs(s), phase(rng));
    if (k > 0) y[n - k] = std::conj(y[k]);
  }
  std::vector<double> out(n);
  for (int t = 0; t < n; ++t) {
    std::complex<double> s = 0;
    for (int k = 0; k < n; ++k) s += y[k] * std::polar(1.0, 2 * M_PI * double(k) * t / n);
    out[t] = s.real() / n;
  }
  return out;
}

// The smoothed recording with, in every shape mode of `raw` that carries shape, the
// detail clean − smoothed added back (phases randomised when `rng` is given); each
// frame keeps the smoothed recording's pose and link length.
Kinematics WithDetail(const Kinematics& raw, const Kinematics& smooth, const Kinematics& clean, std::mt19937_64* rng) {
  auto modes = NoiseWhitenedModes(raw);
  if (!modes.ok()) return smooth;
  const int n = static_cast<int>(smooth.frames.size());
  auto series = [&](const Kinematics& k) {
    std::vector<Eigen::VectorXd> a(n);
    for (int i = 0; i < n; ++i) a[i] = modes->ToModes(ShapeOf(k.frames[i].p));
    return a;
  };
  std::vector<Eigen::VectorXd> a = series(smooth);
  const std::vector<Eigen::VectorXd> c = series(clean);
  for (int m = 0; m < kNumJoints; ++m) {
    if (!(modes->snr[m] > kShapeModeSnr)) continue;
    std::vector<double> d(n);
    for (int i = 0; i < n; ++i) d[i] = c[i][m] - a[i][m];
    if (rng) d = RandomPhases(d, *rng);
    for (int i = 0; i < n; ++i) a[i][m] += d[i];
  }
  Kinematics out = smooth;
  for (int i = 0; i < n; ++i) {
    const Shape shape = modes->FromModes(a[i]);
    const double l = MeanLinkLength(smooth.frames[i].p);
    out.frames[i].p = LabPoints(BestFitPose(smooth.frames[i].p, shape, l), shape, l);
  }
  return out;
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

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{
      "replicate_bench",
      "[--regime agar|water] [--drive real|pattern] [--seed 2] [--draws 6] [--draw-lambda-scale 1]",
      "Refits of fresh noise draws, of bootstrap replicates made from smoothed and from\n"
      "clean shapes, and of the data at other smoothing (docs/estimation.md, \"Intervals\").",
      {{"regime", "agar|water", "the pair's friction regime (noise_bench's truths)", "agar"},
       {"drive", "real|pattern", "the joint angles: the real delta-turn kymogram or the paper's", "real"},
       {"seed", "N", "the pair's seed (noise_bench's)", "2"},
       {"drive-cutoff", "HZ", "low-pass the real kymogram at HZ before it drives the truth (0: raw)", "0"},
       {"draws", "N", "noise draws and replicates per row", "6"},
       {"draw-lambda-scale", "X", "the fresh noise draws' shape smoothing λ times this", "1"},
       {"shape-refit", "", "only: fresh noise draws by Phase 3 and with their shapes refitted", ""},
       {"simex", "", "only: fresh noise draws fitted with noise added and extrapolated to none (SIMEX)", ""},
       {"resemblance", "", "only: the data's E and λ dependence beside their replicates'", ""},
       {"noise-ladder", "LIST", "only: fresh noise draws at each of these noise levels (% BL)", ""},
       {"all-points", "", "score the path on all 14 points, not the paper's joints 3, 7, 10", ""},
       {"shape-refit-iterations", "N", "the shape refit's iterations", "12"},
       {"shape-refit-roughness", "X", "the shape refit's roughness penalty times this", "1"},
       {"shape-refit-knots", "N", "the shape refit's B-spline knots per second", "20"},
       {"shape-refit-from-truth", "", "start the shape refit at the truth and the clean shapes", ""},
       {"lowpass-truths", "LIST", "only: replicates from the data low-passed at each of these cut-offs (Hz)", ""}},
      false};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  Setup s;
  s.regime = args.Get("regime", "agar");
  s.drive = args.Get("drive", "real");
  auto seed = args.GetInt("seed", 2);
  auto draws = args.GetInt("draws", 6);
  auto draw_scale = args.GetDouble("draw-lambda-scale", 1);
  if (!seed.ok() || !draws.ok() || *draws < 1 || !draw_scale.ok() || !(*draw_scale > 0) ||
      (s.regime != "agar" && s.regime != "water") || (s.drive != "real" && s.drive != "pattern"))
    return std::fprintf(stderr, "replicate_bench: bad option (see --help)\n"), 2;
  ShapeRefitOptions refit;
  auto iterations = args.GetInt("shape-refit-iterations", refit.max_iterations);
  auto roughness = args.GetDouble("shape-refit-roughness", refit.roughness_scale);
  auto knots = args.GetDouble("shape-refit-knots", refit.knots_per_second);
  if (!iterations.ok() || !roughness.ok() || !knots.ok())
    return std::fprintf(stderr, "replicate_bench: bad shape refit option (see --help)\n"), 2;
  refit.max_iterations = static_cast<int>(*iterations), refit.roughness_scale = *roughness,
  refit.knots_per_second = *knots;
  if (Status st = refit.Validate(); !st.ok())
    return std::fprintf(stderr, "replicate_bench: %s\n", st.ToString().c_str()), 2;
  s.seed = static_cast<int>(*seed);
  const int n = static_cast<int>(*draws);
  s.truth = bench::FindRegime(s.regime)->truth;
  s.options.estimate.eval.t_max = 5;
  if (args.Has("all-points")) s.options.estimate.eval.points = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13};
  auto cutoff = args.GetDouble("drive-cutoff", 0);
  if (!cutoff.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", cutoff.status().ToString().c_str()), 2;
  auto real = bench::RealShapes(*cutoff);
  if (!real.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", real.status().ToString().c_str()), 2;
  s.real = std::move(*real);

  // The ladder's rows name their own noise.
  const std::string noise = args.Has("noise-ladder") ? "the noise of each row" : FormatNumber(s.noise_bl, 6) + " % BL";
  std::printf("%s-like pair, %s drive, seed %d, %s: %s refitted by Phase 3 from the truth %.3f\n\n", s.regime.c_str(),
              s.drive.c_str(), s.seed, noise.c_str(), s.regime == "agar" ? "K_mu" : "K_eta", Ratio(s, s.truth));
  if (args.Has("shape-refit")) {
    ShapeRefitRow(s, n, refit, args.Has("shape-refit-from-truth"));
    return 0;
  }
  if (args.Has("resemblance")) {
    if (Status st = ResemblanceRow(s, n); !st.ok())
      return std::fprintf(stderr, "replicate_bench: %s\n", st.ToString().c_str()), 1;
    return 0;
  }
  if (args.Has("noise-ladder")) {
    std::vector<double> levels;
    for (const std::string& item : SplitList(args.Get("noise-ladder", ""))) {
      double v = 0;
      if (!flags::ToDouble(item, &v) || !(v >= 0 && v <= 10))
        return std::fprintf(stderr, "replicate_bench: --noise-ladder: '%s' is not a noise level in [0, 10]\n",
                            item.c_str()),
               2;
      levels.push_back(v);
    }
    NoiseLadderRow(s, n, levels);
    return 0;
  }
  if (args.Has("lowpass-truths")) {
    std::vector<double> cutoffs;
    for (const std::string& item : SplitList(args.Get("lowpass-truths", ""))) {
      double v = 0;
      if (!flags::ToDouble(item, &v) || !(v > 0))
        return std::fprintf(stderr, "replicate_bench: --lowpass-truths: '%s' is not a cut-off in Hz\n", item.c_str()),
               2;
      cutoffs.push_back(v);
    }
    return LowpassTruthRows(s, n, cutoffs);
  }
  if (args.Has("simex")) {
    SimexRow(s, n, 2);
    return 0;
  }

  auto data = Draw(s, s.seed);
  if (!data.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", data.status().ToString().c_str()), 1;
  const std::array<Kinematics, 2> raw = {(*data)[0].recording, (*data)[1].recording};
  const std::array<Kinematics, 2> clean = {(*data)[0].clean, (*data)[1].clean};
  auto smoothed = Smoothed(raw, s.options);
  if (!smoothed.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", smoothed.status().ToString().c_str()), 1;
  auto smoothed_pair = PairOf(s, *smoothed, false, s.options);
  auto clean_pair = PairOf(s, clean, false, s.options);
  auto raw_pair = PairOf(s, raw, false, s.options);
  if (!smoothed_pair.ok() || !clean_pair.ok() || !raw_pair.ok())
    return std::fprintf(stderr, "replicate_bench: the pair could not be built\n"), 1;
  std::printf("| refits of | values, sorted |\n|---|---|\n");
  JobOptions draw_options = s.options;
  draw_options.spline.lambda_scale = *draw_scale;
  PrintRow("fresh noise draws of the data", Parallel(n, [&](int i) { return FreshDrawFit(s, i, draw_options); }));
  for (const auto& [label, from] : {std::pair{"replicates from the smoothed data", *smoothed_pair},
                                    std::pair{"replicates from the clean shapes", *clean_pair},
                                    std::pair{"replicates from the unsmoothed data", *raw_pair}})
    PrintRow(label, Parallel(n, [&, from = from](int i) { return TruthReplicateFit(s, *from, i); }));
  for (bool random_phases : {false, true})
    PrintRow(random_phases ? "replicates from the smoothed data + the lost detail, random phases"
                           : "replicates from the smoothed data + the detail smoothing took",
             Parallel(n, [&](int i) {
               std::mt19937_64 rng(1000 + i);
               std::array<Kinematics, 2> g;
               for (int w = 0; w < 2; ++w)
                 g[w] = WithDetail(raw[w], (*smoothed)[w], clean[w], random_phases ? &rng : nullptr);
               auto from = PairOf(s, g, false, s.options);
               return from.ok() ? TruthReplicateFit(s, **from, i) : double(NAN);
             }));
  std::vector<double> at_lambda;
  for (double scale : {0.1, 1.0, 10.0}) {
    JobOptions o = s.options;
    o.spline.lambda_scale = scale;
    auto p = PairOf(s, raw, true, o);
    at_lambda.push_back(p.ok() ? FitFromTruth(s, *p) : NAN);
  }
  std::printf("| the data at λ × 0.1, 1, 10 | %.3f %.3f %.3f |\n\n", at_lambda[0], at_lambda[1], at_lambda[2]);

  // GCV's λ per shape mode over the noise draws (worm 1, one run: the whole recording).
  std::vector<std::vector<double>> log_lambda(kNumJoints);
  std::vector<double> snr(kNumJoints, 0);
  for (int i = 0; i < n; ++i) {
    auto d = Draw(s, s.seed + 100 * (i + 1));
    if (!d.ok()) continue;
    const Kinematics& k = (*d)[0].recording;
    auto modes = NoiseWhitenedModes(k);
    if (!modes.ok()) continue;
    std::vector<std::vector<double>> series(kNumJoints);
    for (const Frame& f : k.frames) {
      const Eigen::VectorXd c = modes->ToModes(ShapeOf(f.p));
      for (int m = 0; m < kNumJoints; ++m) series[m].push_back(c[m]);
    }
    for (int m = 0; m < kNumJoints; ++m) {
      SmoothingSplineOptions o;
      if (!(modes->snr[m] > kShapeModeSnr)) o.max_fundamental_loss = 0;
      auto r = SmoothByGcv(series[m], o);
      if (r.ok()) log_lambda[m].push_back(std::log10(r->lambda)), snr[m] += modes->snr[m] / n;
    }
  }
  std::printf("| shape mode | mean SNR | mean log10 λ | SD |\n|---|---|---|---|\n");
  for (int m = 0; m < kNumJoints; ++m) {
    const auto& v = log_lambda[m];
    if (v.size() < 2) continue;
    double mean = 0, var = 0;
    for (double x : v) mean += x / v.size();
    for (double x : v) var += (x - mean) * (x - mean) / (v.size() - 1);
    std::printf("| %d | %.3g | %.2f | %.2f |\n", m + 1, snr[m], mean, std::sqrt(var));
  }
  return 0;
}
