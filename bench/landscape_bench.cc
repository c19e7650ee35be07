// E along the ratio a regime determines, with the truth's other coefficients, on a
// synthetic pair processed four ways (docs/estimation.md, "What noise leaves
// undetermined"): where tracking noise moves the minimum, and through which input.
//
//   landscape_bench [--regime agar|water] [--noise 0.5] [--seed 1] [--drive pattern|real]
//                   [--drive-cutoff HZ] [--factors F,F,...] [--doses R] [--dose-variance K]
//
// Rows: the clean pair; the noisy pair smoothed as the estimator does (auto); the
// clean shapes driving the model with the smoothed pose and length of the noisy pair
// (the noise reaches only the scored points); the smoothed noisy shapes driving it
// with the clean pose. Columns: E (% BL) at the truth's ratio × the column's factor.
//
// With --doses R, a second table gives the pair a second dose of drive error
// (docs/decisions/0050-second-dose-of-drive-error.md): R copies of the smoothed pair
// get fresh noise of K times the pair's variance and are smoothed again, and each drives
// the model against the pair's own smoothed points. Its rows are mean squared distances
// (µm²): the data's F, the copies' mean F₂, the drive variance V (the copies' mean
// squared path change), the corrections F − V, 2F − F₂ and the path extrapolated to no
// drive error linearly in the variance and in the SD; then the copies' mean path change
// and its cosine with the data's residual.
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/noise_pairs.h"
#include "core/common/flags.h"
#include "core/diagnose/synth.h"
#include "core/estimate/paired_path.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"

using namespace wormdrag;

namespace {

// Frames with `shapes`' shape placed at `poses`' best-fit pose and link length.
Kinematics Combine(const Kinematics& shapes, const Kinematics& poses) {
  Kinematics out = poses;
  for (size_t f = 0; f < out.frames.size(); ++f) {
    if (!out.frames[f].valid) continue;
    const Shape q = ShapeOf(shapes.frames[f].p);
    const Points& p = poses.frames[f].p;
    const double l = MeanLinkLength(p);
    out.frames[f].p = LabPoints(BestFitPose(p, q, l), q, l);
  }
  return out;
}

void Row(const char* label, const std::array<Kinematics, 2>& pair, const std::vector<Coefficients>& sets) {
  EvaluationOptions o;
  auto p = PairedPath::Create(pair, {"worm 1", "worm 2"}, o);
  if (!p.ok()) {
    std::printf("%s: %s\n", label, p.status().ToString().c_str());
    return;
  }
  LocalEvaluator ev(*p, DefaultThreads());
  std::vector<double> e;
  if (!ev.Evaluate(sets, &e).ok()) return;
  std::printf("| %s |", label);
  for (double v : e) std::printf(" %.3f |", 100 * v / (*p)->mean_body_length());
  std::printf("\n");
}

// The residual vector (scaled as the evaluator scales it: Σ r² is the mean squared
// distance) of each set on `pair`; false when a run failed.
bool Residuals(const std::shared_ptr<const PairedPath>& pair, const std::vector<Coefficients>& sets,
               std::vector<std::vector<double>>* r) {
  LocalEvaluator ev(pair, DefaultThreads());
  if (!ev.EvaluateResiduals(sets, r).ok()) return false;
  for (const auto& v : *r)
    if (v.empty()) return false;
  return true;
}

// `copy`'s measured points minus `base`'s, laid out and scaled as the residuals.
std::vector<double> MeasuredShift(const PairedPath& base, const PairedPath& copy) {
  const double scale = 1.0 / std::sqrt(static_cast<double>(base.scored_count()));
  std::vector<double> d;
  for (int j = 0; j < 2; ++j)
    for (size_t f = 0; f < base.worm(j).frames.size(); ++f)
      for (size_t k = 0; k < base.worm(j).frames[f].measured.size(); ++k) {
        const Vec2 v = copy.worm(j).frames[f].measured[k] - base.worm(j).frames[f].measured[k];
        d.push_back(scale * v.x());
        d.push_back(scale * v.y());
      }
  return d;
}

double SumSq(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return s;
}

// The pair's residuals r and, over the copies given a second dose of drive error, the
// mean of their residuals against the pair's points, their mean squared distance F₂ and
// their mean squared change from r (V), per set.
struct Doses {
  std::vector<std::vector<double>> r, mean2;
  std::vector<double> f2, v;
};

Status RunDoses(const std::array<Kinematics, 2>& smoothed, double sigma, int doses,
                const std::vector<Coefficients>& sets, Doses* out) {
  EvaluationOptions o;
  auto base = PairedPath::Create(smoothed, {"worm 1", "worm 2"}, o);
  if (!base.ok()) return base.status();
  if (!Residuals(*base, sets, &out->r)) return Status::Internal("a run on the pair failed");
  const size_t n = sets.size(), m = out->r[0].size();
  out->f2.assign(n, 0);
  out->v.assign(n, 0);
  out->mean2.assign(n, std::vector<double>(m, 0.0));
  for (int d = 0; d < doses; ++d) {
    std::array<Kinematics, 2> copy;
    for (int w = 0; w < 2; ++w) {
      Kinematics k = smoothed[w];
      diagnose::AddTrackingNoise(&k, sigma, 777000 + 10 * d + w);
      auto sm = SmoothRecording("copy", k, JobOptions{});
      if (!sm.ok()) return sm.status();
      copy[w] = std::move(*sm);
    }
    auto p = PairedPath::Create(copy, {"copy 1", "copy 2"}, o);
    if (!p.ok()) return p.status();
    std::vector<std::vector<double>> r;
    if (!Residuals(*p, sets, &r)) return Status::Internal("a run on copy " + std::to_string(d) + " failed");
    const std::vector<double> shift = MeasuredShift(**base, **p);
    for (size_t i = 0; i < n; ++i)
      for (size_t q = 0; q < m; ++q) {
        const double e = r[i][q] + shift[q];  // the copy's path against the pair's points
        out->f2[i] += e * e / doses;
        out->v[i] += (e - out->r[i][q]) * (e - out->r[i][q]) / doses;
        out->mean2[i][q] += e / doses;
      }
  }
  return Status::Ok();
}

// The second table; k is the copies' added variance over the pair's.
void PrintDoses(const Doses& d, double k, int doses, const std::vector<double>& factors) {
  const size_t n = factors.size(), m = d.r[0].size();
  std::printf(
      "\nA second dose of drive error (%d copies, %.3g × the variance), mean squared distance (µm²) at "
      "the truth's ratio ×\n\n| |",
      doses, k);
  for (double f : factors) std::printf(" %.3g |", f);
  std::printf("\n|---|");
  for (size_t i = 0; i < n; ++i) std::printf("---|");
  std::printf("\n");
  auto row = [&](const char* label, auto value, double unit = 1e6) {
    std::printf("| %s |", label);
    for (size_t i = 0; i < n; ++i) std::printf(" %.4g |", unit * value(i));
    std::printf("\n");
  };
  // ‖r − c (mean r₂ − r)‖²: the path extrapolated to no drive error.
  auto extrapolated = [&](size_t i, double c) {
    double s = 0;
    for (size_t q = 0; q < m; ++q) {
      const double e = d.r[i][q] - c * (d.mean2[i][q] - d.r[i][q]);
      s += e * e;
    }
    return s;
  };
  row("F, the pair", [&](size_t i) { return SumSq(d.r[i]); });
  row("F₂, the copies", [&](size_t i) { return d.f2[i]; });
  row("V, drive variance", [&](size_t i) { return d.v[i]; });
  row("F − V", [&](size_t i) { return SumSq(d.r[i]) - d.v[i]; });
  row("F − (F₂ − F) / k", [&](size_t i) { return SumSq(d.r[i]) - (d.f2[i] - SumSq(d.r[i])) / k; });
  row("path, linear in the variance", [&](size_t i) { return extrapolated(i, 1 / k); });
  row("path, linear in the SD", [&](size_t i) { return extrapolated(i, 1 / (std::sqrt(1 + k) - 1)); });
  row("‖mean r₂ − r‖²", [&](size_t i) {
    double s = 0;
    for (size_t q = 0; q < m; ++q) s += (d.mean2[i][q] - d.r[i][q]) * (d.mean2[i][q] - d.r[i][q]);
    return s;
  });
  row(
      "cos(r, mean r₂ − r)",
      [&](size_t i) {
        double s = 0, a = 0, b = 0;
        for (size_t q = 0; q < m; ++q) {
          const double e = d.mean2[i][q] - d.r[i][q];
          s += d.r[i][q] * e, a += d.r[i][q] * d.r[i][q], b += e * e;
        }
        return s / std::sqrt(a * b);
      },
      1);
}

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{"landscape_bench",
                         "[--regime agar|water] [--noise 0.5] [--seed 1] [--drive pattern|real] [--drive-cutoff HZ]\n"
                         "       [--factors F,F,...] [--doses R] [--dose-variance K]",
                         "E along the ratio a regime determines on a synthetic pair processed four ways\n"
                         "(docs/estimation.md, \"What noise leaves undetermined\").",
                         {{"regime", "agar|water", "the pair's friction regime", "agar"},
                          {"noise", "PCT", "tracking noise, % of the body length", "0.5"},
                          {"seed", "N", "the pair's seed", "1"},
                          {"drive", "pattern|real", "the paper's pattern or the real delta-turn kymogram", "pattern"},
                          {"drive-cutoff", "HZ", "low-pass of the real kymogram (0 = raw)", "0"},
                          {"doses", "R", "copies for the second dose of drive error (0 = no such table)", "0"},
                          {"dose-variance", "K", "the copies' added noise variance, × the pair's", "1"},
                          {"factors", "F,F,...", "the columns: factors on the truth's ratio",
                           "0.83 … 333 agar-like, 0.8 … 1.33 water-like"}},
                         false};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const std::string regime = args.Get("regime", "agar");
  const auto noise_arg = args.GetDouble("noise", 0.5);
  const auto seed_arg = args.GetInt("seed", 1);
  const auto doses_arg = args.GetInt("doses", 0);
  const auto cutoff_arg = args.GetDouble("drive-cutoff", 0);
  const auto dose_var_arg = args.GetDouble("dose-variance", 1);
  const std::string drive = args.Get("drive", "pattern");
  if (drive != "pattern" && drive != "real")
    return flags::Fail("landscape_bench",
                       Status::InvalidArgument("--drive must be pattern or real, not '" + drive + "'"));
  for (const Status& st :
       {noise_arg.status(), seed_arg.status(), doses_arg.status(), cutoff_arg.status(), dose_var_arg.status()})
    if (!st.ok()) return flags::Fail("landscape_bench", st);
  const double noise = *noise_arg;
  const int seed = static_cast<int>(*seed_arg);
  if (regime != "agar" && regime != "water")
    return flags::Fail("landscape_bench",
                       Status::InvalidArgument("--regime must be agar or water, not '" + regime + "'"));
  if (!(*dose_var_arg > 0) || *doses_arg < 0)
    return flags::Fail("landscape_bench", Status::InvalidArgument("--doses must be >= 0 and --dose-variance > 0"));
  const bool water = regime == "water";
  const Coefficients truth = water ? Coefficients{0, 0, 0.003, 0.002} : Coefficients{0.6, 0.2, 0.0012, 0.0004};
  std::vector<double> factors = water ? std::vector<double>{0.8, 0.9, 0.95, 1, 1.05, 1.1, 1.33}
                                      : std::vector<double>{0.83, 0.93, 1, 1.15, 1.33, 1.7, 2.33, 16.7, 333};
  std::string bad;
  if (args.Has("factors") && !flags::ToDoubles(
                                 args.Get("factors", ""), [](double v) { return v > 0; }, &factors, &bad))
    return flags::Fail("landscape_bench", Status::InvalidArgument("--factors: '" + bad + "' is not a positive number"));
  std::vector<Coefficients> sets;
  for (double f : factors) {
    Coefficients c = truth;
    (water ? c.eta_n : c.mu_n) *= f;
    sets.push_back(c);
  }
  Kinematics real;
  if (drive == "real") {
    auto k = bench::RealShapes(*cutoff_arg);
    if (!k.ok()) return std::fprintf(stderr, "%s\n", k.status().ToString().c_str()), 1;
    real = std::move(*k);
  }
  auto made = bench::SynthesizePair(truth, drive, noise, seed, seed, 300, 5, &real);
  if (!made.ok()) return std::fprintf(stderr, "%s\n", made.status().ToString().c_str()), 1;
  std::array<Kinematics, 2> clean, smoothed, clean_shapes, clean_pose;
  for (int w = 0; w < 2; ++w) {
    const diagnose::SynthOutput& s = (*made)[w];
    auto sm = SmoothRecording("worm", s.recording, JobOptions{});
    if (!sm.ok()) return std::fprintf(stderr, "%s\n", sm.status().ToString().c_str()), 1;
    clean[w] = s.clean;
    smoothed[w] = *sm;
    clean_shapes[w] = Combine(s.clean, *sm);
    clean_pose[w] = Combine(*sm, s.clean);
  }
  std::printf("%s-like pair (truth %s = %.3g), %.2g %% BL noise, seed %d: E (%% BL) at the truth's ratio ×\n\n| |",
              regime.c_str(), water ? "K_eta" : "K_mu", water ? truth.K_eta() : truth.K_mu(), noise, seed);
  for (double f : factors) std::printf(" %.3g |", f);
  std::printf("\n|---|");
  for (size_t i = 0; i < factors.size(); ++i) std::printf("---|");
  std::printf("\n");
  Row("clean", clean, sets);
  Row("noisy, smoothed (auto)", smoothed, sets);
  Row("clean shapes, smoothed pose", clean_shapes, sets);
  Row("smoothed shapes, clean pose", clean_pose, sets);
  if (*doses_arg > 0) {
    const double sigma = std::sqrt(*dose_var_arg) * noise / 100 * diagnose::SynthSpec{}.body.length;
    Doses d;
    const Status st = RunDoses(smoothed, sigma, static_cast<int>(*doses_arg), sets, &d);
    if (!st.ok()) return flags::Fail("landscape_bench", st);
    PrintDoses(d, *dose_var_arg, static_cast<int>(*doses_arg), factors);
  }
  return 0;
}
