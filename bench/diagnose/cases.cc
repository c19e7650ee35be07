// The benchmark's synthetic cases: their truths and coefficients, the pairs of
// recordings made from them, one case diagnosed, and the truth's own held-out scores.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>

#include "bench/diagnose/bench.h"
#include "bench/kymogram_source.h"
#include "core/diagnose/synth.h"

namespace wormdrag::diagnose_bench {
namespace {

// Effect strengths (weak, medium, strong) of the catalogue, and the outside effects.
EffectParams Inject(const std::string& name, int s) {
  EffectParams p;
  static const std::map<std::string, std::vector<std::vector<double>>> kValues = {
      {"body_gradient", {{0.4}, {0.8}, {1.4}}}, {"time_drift", {{0.4}, {0.8}, {1.4}}},
      {"power_law", {{0.8}, {0.6}, {0.35}}},    {"stiction", {{1.0}, {2.5}, {5.0}}},
      {"lag", {{0.02}, {0.05}, {0.1}}},         {"flow", {{0.005, 0.0}, {0.01, -0.005}, {0.02, 0.01}}},
      {"gap_offset", {{0.3}, {0.7}, {1.5}}},    {"lateral_asymmetry", {{0.2}, {0.5}, {1.0}}},
      {"stretch", {{0.05}, {0.1}, {0.15}}},     {"tether", {{0.5}, {2.0}, {5.0}}},
      {"boundary", {{1.5}, {4.0}, {10.0}}},
  };
  if (name == "none") return p;
  SetParams(&p, *ParseEffectName(name), kValues.at(name)[s]);
  return p;
}

}  // namespace

std::string ArgS(const flags::Args& args, const char* name, const std::string& fb) {
  return args.Get(name + 2, fb);
}
double Arg(const flags::Args& args, const char* name, double fb) {
  const std::string v = ArgS(args, name, "");
  return v.empty() ? fb : std::atof(v.c_str());
}
bool Flag(const flags::Args& args, const char* name) {
  return args.Has(name + 2);
}
void CreateParentFolder(const std::string& path) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path(), ec);
}

std::vector<Case> MakeCases(uint64_t set_seed) {
  std::mt19937_64 rng(set_seed);
  std::uniform_real_distribution<double> U(0, 1);
  auto coef = [&]() {
    const double mu_t = 0.1 + 0.4 * U(rng), eta_t = 0.001 + 0.004 * U(rng);
    return Coefficients{mu_t * (1.5 + 2.5 * U(rng)), mu_t, eta_t * (1.5 + 2.5 * U(rng)), eta_t};
  };
  std::vector<Case> cases;
  int k = 0;
  auto add = [&](const std::string& cat, const std::string& eff, int s) {
    Case c;
    c.category = cat;
    c.effect = eff;
    c.strength = s;
    c.truth = Inject(eff, s);
    c.coef = coef();
    c.source = k % 2;
    c.seed = set_seed * 1000 + k;
    DrawConditions(FamilyOfSet(set_seed), k, &c);
    ++k;
    cases.push_back(c);
  };
  for (int i = 0; i < 11; ++i) add("none", "none", 0);
  const char* cat[] = {"body_gradient", "time_drift", "power_law",  "stiction",
                       "lag",           "flow",       "gap_offset", "lateral_asymmetry"};
  for (const char* e : cat)
    for (int s = 0; s < 3; ++s) add("catalogue", e, s);
  for (const char* e : {"stretch", "tether", "boundary"})
    for (int s = 0; s < 3; ++s) add("outside", e, s);
  return cases;
}

bool CaseBySeed(uint64_t seed, Case* c) {
  const auto cases = MakeCases(seed / 1000);
  if (seed % 1000 >= cases.size()) return false;
  *c = cases[seed % 1000];
  return true;
}

Result<Sources> LoadSources(double cutoff_hz) {
  Sources src;
  for (int i = 0; i < 2; ++i) {
    const std::string path = std::string(WORMDRAG_SHARED_DIR) + "/data/real/elegansbot/kymogram_" +
                             (i ? "delta" : "omega") + "-turn.npy";
    auto k = bench::KymogramShapes(path, path, cutoff_hz);
    if (!k.ok()) return k.status();
    (i ? src.delta : src.omega) = std::move(*k);
  }
  return src;
}

Result<std::array<Kinematics, 2>> Synth(const Case& c, const Sources& src, double fps, double duration, double noise,
                                        uint64_t noise_seed_offset) {
  fps = FpsOf(c, fps);
  duration = DurationOf(c, duration);
  if (noise > 0) noise = NoiseOf(c, noise);
  std::array<Kinematics, 2> out;
  for (int j = 0; j < 2; ++j) {
    SynthSpec s;
    s.coef = c.coef;
    s.effects = c.truth;
    s.fps = fps;
    s.duration = duration;
    s.noise = noise;  // 0.002: 0.2 % of the 1 mm body per coordinate
    s.seed = c.seed * 2 + j + noise_seed_offset;
    // The truth is simulated at >= 600 knots/s whatever the frame rate, several times
    // finer than any fit, so that its own discretisation error is negligible.
    s.substeps = std::max(2, static_cast<int>(std::ceil(600.0 / fps)));
    s.gaps.every = static_cast<int>(std::lround(src.gap_every_s * fps));
    s.gaps.length = std::max(2, static_cast<int>(std::lround(0.04 * fps)));
    if (c.source == 0) {
      s.pattern = Locomotion(j == 0 ? 1 + 2 * (c.seed % 2) : 2 + 2 * (c.seed % 2));
    } else if (c.source == 2) {
      s.pattern = c.waves[j];
    } else {
      s.shapes = j == 0 ? &src.omega : &src.delta;
      const double span = s.shapes->Duration() - duration - 0.1;
      s.shapes_offset = std::fmod(0.37 * static_cast<double>(c.seed % 97), std::max(0.1, span));
    }
    auto r = Synthesize(s);
    if (!r.ok()) return r.status();
    out[j] = std::move(r->recording);
  }
  return out;
}

double TrueModelE(const EffectData& d, const Case& c, double eps, double* mse, bool blocked) {
  const BlockScores s = ScoreBlocks(d, c.coef, c.truth, blocked, eps);
  double a = 0, a2 = 0, n = 0;
  for (size_t i = 0; i < s.sum.size(); ++i) {
    a += s.sum[i];
    a2 += s.sum_sq[i];
    n += s.count[i];
  }
  if (mse) *mse = a2 / n;
  return a / n;
}

bool FittedTruth(const EffectData& d, const Case& c, double noise_sigma, const DiagnoseOptions& o, double* e,
                 double* mse) {
  const auto ef = ParseEffectName(c.effect);
  if (!ef.ok()) return false;
  double a = 0, a2 = 0, n = 0;
  for (int parity = 0; parity < 2; ++parity) {
    FitSpec fs;
    fs.has_effect = true;
    fs.effect = *ef;
    fs.effect_starts = {GetParams(c.truth, *ef)};
    fs.start = c.coef;
    fs.prior = c.coef;
    fs.prior_weight = o.cv_ridge * std::sqrt(2.0) * noise_sigma;
    fs.train_parity = parity;
    fs.iterations = o.grg_iterations;
    fs.epsilon = o.epsilon;
    fs.threads = o.threads;
    auto r = FitModel(d, fs);
    if (!r.ok()) return false;
    const BlockScores s = ScoreBlocks(d, r->coef, r->effects, true, o.epsilon);
    for (size_t i = 0; i < s.sum.size(); ++i)
      if (static_cast<int>(i % d.blocks) % 2 != parity) {
        a += s.sum[i];
        a2 += s.sum_sq[i];
        n += s.count[i];
      }
  }
  *e = a / n;
  *mse = a2 / n;
  return std::isfinite(*mse);
}

double GapOffsetFrom(const EffectData& d, const Coefficients& c, const DiagnoseOptions& o) {
  FitSpec fs;
  fs.has_effect = true;
  fs.effect = Effect::kGapOffset;
  fs.effect_starts = EffectStarts(Effect::kGapOffset);
  fs.start = c;
  fs.iterations = o.grg_iterations;
  fs.epsilon = o.epsilon;
  auto fit = FitModel(d, fs);
  return fit.ok() && !fit->params.empty() ? fit->params[0] : NAN;
}

Result<std::array<Kinematics, 2>> NullPair(const EffectData& d, const Coefficients& c, double eps, double sigma,
                                           int r) {
  std::array<Kinematics, 2> rec;
  for (int j = 0; j < 2; ++j) {
    auto k = NullRecording(d.worms[j], c, eps, sigma, 77 + 1000 * r + j);
    if (!k.ok()) return k.status();
    rec[j] = std::move(*k);
  }
  return rec;
}

Outcome RunCase(const Case& c, const Sources& src, const DiagnoseOptions& options, double fps, double duration,
                double noise) {
  DiagnoseOptions o = options;
  o.t_max = DurationOf(c, duration);
  Outcome x;
  x.c = c;
  const auto t0 = std::chrono::steady_clock::now();
  auto ks = Synth(c, src, fps, duration, noise);
  if (!ks.ok()) {
    x.error = ks.status().ToString();
    return x;
  }
  auto d = RunDiagnosis(*ks, {"worm1", "worm2"}, o);
  if (!d.ok()) {
    x.error = d.status().ToString();
    return x;
  }
  x.d = std::move(*d);
  // The true model's held-out E (no fitting: the truth is known).
  auto data = PrepareForDiagnosis(*ks, o);
  if (data.ok()) x.e_true = TrueModelE(*data, c, o.epsilon, &x.mse_true);
  if (data.ok() && c.category == "catalogue" &&
      !FittedTruth(*data, c, x.d.noise_sigma, o, &x.e_fitted_truth, &x.mse_fitted_truth))
    x.mse_fitted_truth = -1;
  x.ok = true;
  x.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return x;
}

int SynthCaseOf(const Bench& b, const char* flag, Case* c, std::array<Kinematics, 2>* ks) {
  const int seed = static_cast<int>(Arg(b.args, flag, -1));
  if (!CaseBySeed(seed, c)) {
    std::fprintf(stderr, "no benchmark case %d\n", seed);
    return 2;
  }
  auto k = Synth(*c, b.src, b.fps, b.duration, Arg(b.args, "--noise", 0.002));
  if (!k.ok()) {
    std::fprintf(stderr, "%s\n", k.status().ToString().c_str());
    return 1;
  }
  *ks = std::move(*k);
  return 0;
}

int LoadPair(const Bench& b, const char* mode, LoadedPair* out) {
  const flags::Args& args = b.args;
  const std::string files = ArgS(args, "--files", ""), cs = ArgS(args, "--coef", "");
  const size_t comma = files.find(',');
  const int case_seed = static_cast<int>(Arg(args, "--case", -1));
  if (case_seed >= 0 && CaseBySeed(case_seed, &out->c)) {
    out->coef = out->c.coef;
    auto k = Synth(out->c, b.src, b.fps, b.duration, Arg(args, "--noise", 0.002));
    if (!k.ok()) {
      std::fprintf(stderr, "%s\n", k.status().ToString().c_str());
      return 1;
    }
    out->k = std::move(*k);
  } else if (comma != std::string::npos && !cs.empty()) {
    out->c.effect = "recorded";
    out->c.seed = 0;
    for (int j = 0; j < 2; ++j) {
      auto k = ReadKinematics(j == 0 ? files.substr(0, comma) : files.substr(comma + 1));
      if (!k.ok()) {
        std::fprintf(stderr, "%s\n", k.status().ToString().c_str());
        return 1;
      }
      out->k[j] = std::move(*k);
    }
  } else {
    std::fprintf(stderr, "%s needs --case SEED [--coef ...], or --files K1.csv,K2.csv --coef MU_N,MU_T,ETA_N,ETA_T\n",
                 mode);
    return 2;
  }
  Coefficients& c = out->coef;
  if (!cs.empty() && std::sscanf(cs.c_str(), "%lf,%lf,%lf,%lf", &c.mu_n, &c.mu_t, &c.eta_n, &c.eta_t) != 4) {
    std::fprintf(stderr, "--coef needs MU_N,MU_T,ETA_N,ETA_T\n");
    return 2;
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
