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
// variables), optionally from the truth and the clean shapes. --simex, --resemblance,
// --noise-ladder and --predicted-detail are single studies of their own (see each one's
// function).
//
//   replicate_bench [--regime agar|water] [--drive real|pattern] [--seed 2] [--draws 6]
//                   [--draw-lambda-scale 1] [--shape-refit [--shape-refit-iterations 12]
//                   [--shape-refit-roughness 1] [--shape-refit-knots 20] [--shape-refit-from-truth]]
//                   [--simex] [--resemblance] [--noise-ladder 0,0.05,0.2,0.5]
//                   [--predicted-detail [--detail-harmonics H]]
//                   [--all-points]
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "bench/noise_pairs.h"
#include "bench/replicate_setup.h"
#include "core/common/flags.h"
#include "core/common/format.h"
#include "core/filter/shape_modes.h"
#include "core/filter/shape_smoothing.h"
#include "core/filter/smoothing_spline.h"
#include "core/model/body.h"

using namespace wormdrag;
using namespace wormdrag::bench;

namespace {

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
  Eigen::MatrixXd a = ModeSeries(*modes, smooth);
  const Eigen::MatrixXd c = ModeSeries(*modes, clean);
  for (int m = 0; m < kNumJoints; ++m) {
    if (!(modes->snr[m] > kShapeModeSnr)) continue;
    std::vector<double> d(n);
    for (int i = 0; i < n; ++i) d[i] = c(i, m) - a(i, m);
    if (rng) d = RandomPhases(d, *rng);
    for (int i = 0; i < n; ++i) a(i, m) += d[i];
  }
  return WithModeShapes(smooth, *modes, a);
}

// GCV's λ per shape mode over the noise draws (worm 1, one run: the whole recording):
// the mean and SD of log₁₀ λ.
void LambdaSpread(const Setup& s, int n) {
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
}

// The default study: the rows of the header, from one noise draw of the pair.
int DefaultRows(const Setup& s, int n, double draw_scale) {
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
  draw_options.spline.lambda_scale = draw_scale;
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
  LambdaSpread(s, n);
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
       {"lowpass-truths", "LIST", "only: replicates from the data low-passed at each of these cut-offs (Hz)", ""},
       {"predicted-detail", "", "only: fresh noise draws with the lost detail regressed on the smoothed modes", ""},
       {"detail-harmonics", "H", "--predicted-detail regresses on H harmonics of the gait's phase (0 = monomials)",
        "0"}},
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
  s.truth = FindRegime(s.regime)->truth;
  s.options.estimate.eval.t_max = 5;
  if (args.Has("all-points")) s.options.estimate.eval.points = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13};
  auto cutoff = args.GetDouble("drive-cutoff", 0);
  if (!cutoff.ok()) return std::fprintf(stderr, "replicate_bench: %s\n", cutoff.status().ToString().c_str()), 2;
  auto real = RealShapes(*cutoff);
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
    std::string bad;
    if (!flags::ToDoubles(
            args.Get("noise-ladder", ""), [](double v) { return v >= 0 && v <= 10; }, &levels, &bad))
      return std::fprintf(stderr, "replicate_bench: --noise-ladder: '%s' is not a noise level in [0, 10]\n",
                          bad.c_str()),
             2;
    NoiseLadderRow(s, n, levels);
    return 0;
  }
  if (args.Has("lowpass-truths")) {
    std::vector<double> cutoffs;
    std::string bad;
    if (!flags::ToDoubles(
            args.Get("lowpass-truths", ""), [](double v) { return v > 0; }, &cutoffs, &bad))
      return std::fprintf(stderr, "replicate_bench: --lowpass-truths: '%s' is not a cut-off in Hz\n", bad.c_str()), 2;
    return LowpassTruthRows(s, n, cutoffs);
  }
  if (args.Has("predicted-detail")) {
    const auto h = args.GetInt("detail-harmonics", 0);
    if (!h.ok() || *h < 0 || *h > 20)
      return std::fprintf(stderr, "replicate_bench: --detail-harmonics must be a whole number 0 … 20\n"), 2;
    return PredictedDetailRows(s, n, static_cast<int>(*h));
  }
  if (args.Has("simex")) {
    SimexRow(s, n, 2);
    return 0;
  }

  return DefaultRows(s, n, *draw_scale);
}
