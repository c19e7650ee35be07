// wormdrag verify: the paper's §3.1 experiment. Preset coefficient sets F1…F10 drawn
// from a fixed seed drive Locomotion 1–4 (pairs L1+L2 for F1–F5, L3+L4 for F6–F10);
// the full pipeline must find them again from the simulated paths.
#include <sys/stat.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>

#include "client/cli.h"
#include "client/commands.h"
#include "client/progress.h"
#include "core/common/format.h"
#include "core/common/json.h"
#include "core/estimate/estimator.h"
#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"

namespace wormdrag::cli {
namespace {

struct Row {
  int index;
  Coefficients preset, estimate;
  double e_mm = 0, e_percent = 0, seconds = 0;
  std::string identifiability;
};

Json Numbers(std::initializer_list<double> v) {
  Json a = Json::array();
  for (double x : v) a.push_back(NumberOrNull(x));
  return a;
}

double PctErr(double est, double truth) {
  return 100.0 * (est - truth) / truth;
}

// A number of verify.csv: an empty cell where it is undefined (an estimate's ratio 0/0).
std::string CsvCell(double v) {
  return std::isnan(v) ? "" : FormatNumber(v, 6);
}

// An error of a ratio in the table: undefined where the estimate's ratio is 0/0.
std::string SignedPercent(double v) {
  if (std::isnan(v)) return "undefined";
  char b[32];
  std::snprintf(b, sizeof b, "%+.4f", v);
  return b;
}

// Gaussian tracking noise of standard deviation sigma (mm) on every point.
void AddNoise(Kinematics* k, double sigma, std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, sigma);
  for (auto& f : k->frames)
    for (auto& p : f.p) p += Vec2(n(*rng), n(*rng));
}

// F1…F10, in the order (μ_n, μ_t, η_n, η_t): uniform on [0,1]² × [0,0.01]².
std::vector<Coefficients> PresetSets(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> mu(0.0, 1.0), eta(0.0, 0.01);
  std::vector<Coefficients> F(10);
  for (auto& c : F) {
    c.mu_n = mu(rng);
    c.mu_t = mu(rng);
    c.eta_n = eta(rng);
    c.eta_t = eta(rng);
  }
  return F;
}

struct VerifySetup {
  double noise = 0;  // fraction of the body length
  double fps = 300;
  int threads = 1;
  JobOptions job;  // smoothing of noisy recordings, and the estimate's options
};

// Simulates preset set F`index` on its pair, adds the noise, smooths as `estimate`
// does, and estimates it again.
Result<Row> VerifySet(int index, const Coefficients& c, const VerifySetup& v, std::mt19937_64* noise_rng,
                      ProgressBar* bar) {
  const int la = index <= 5 ? 1 : 3;
  const EstimateOptions& eo = v.job.estimate;
  const std::array<std::string, 2> names = {"L" + std::to_string(la), "L" + std::to_string(la + 1)};
  std::array<Kinematics, 2> rec;
  for (int w = 0; w < 2; ++w) {
    RecordingSpec spec;
    spec.fps = v.fps;
    spec.duration = eo.eval.t_max;
    spec.substeps = eo.eval.SubstepsFor(v.fps);
    spec.as_estimated = true;
    auto k = GenerateRecording(Locomotion(la + w), c, eo.eval.sim, spec);
    if (!k.ok()) return k.status();
    if (v.noise > 0) {
      AddNoise(&*k, v.noise * spec.body.length, noise_rng);
      k = SmoothRecording(names[w], *k, v.job);
      if (!k.ok()) return k.status();
    }
    rec[w] = std::move(*k);
  }
  auto accurate = PairedPath::Create(rec, names, eo.eval);
  if (!accurate.ok()) return accurate.status();
  auto screening = PairedPath::Create(rec, names, eo.ScreeningEval());
  if (!screening.ok()) return screening.status();
  LocalEvaluator fast(*screening, v.threads), acc(*accurate, v.threads);
  EstimateHooks hooks;
  const std::string tag = "F" + std::to_string(index) + " ";
  hooks.progress = [&](const std::string& phase, int64_t d, int64_t t, double b) { bar->Update(tag + phase, d, t, b); };
  const auto t0 = std::chrono::steady_clock::now();
  auto r = RunEstimate(fast, acc, eo, (*accurate)->mean_body_length(), hooks);
  bar->Finish();
  if (!r.ok()) return r.status();
  return Row{index,
             c,
             r->best.set,
             r->best.e,
             r->e_percent,
             std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
             r->identifiability.plain_language};
}

// The table (the paper's Fig. 3–4) on stdout, then the summary; the CSV and JSON of the
// same rows into `out` when it is given.
Status ReportRows(const std::vector<Row>& rows, double noise, const std::string& out) {
  std::string csv =
      "set,pair,mu_n,mu_t,eta_n,eta_t,est_mu_n,est_mu_t,est_eta_n,est_eta_t,err_mu_n_pct,err_mu_t_pct,err_eta_n_pct,"
      "err_eta_t_pct,err_K_mu_pct,err_K_eta_pct,err_v_c_pct,E_mm,E_pct_BL,seconds\n";
  Json json = Json::array();
  std::printf("%-4s %-6s %-34s %-34s %-30s %-26s %s\n", "set", "pair", "preset (mu_n,mu_t,eta_n,eta_t)", "estimate",
              "% error (mu_n,mu_t,eta_n,eta_t)", "% error (K_mu,K_eta,v_c)", "path E mm (% BL)");
  double max_comb = 0, sum_e = 0, max_e = 0;
  for (const Row& r : rows) {
    const Coefficients &p = r.preset, &e = r.estimate;
    const double em[4] = {PctErr(e.mu_n, p.mu_n), PctErr(e.mu_t, p.mu_t), PctErr(e.eta_n, p.eta_n),
                          PctErr(e.eta_t, p.eta_t)};
    const double ec[3] = {PctErr(e.K_mu(), p.K_mu()), PctErr(e.K_eta(), p.K_eta()), PctErr(e.v_c(), p.v_c())};
    for (double v : ec) max_comb = std::max(max_comb, std::abs(v));
    sum_e += r.e_percent;
    max_e = std::max(max_e, r.e_percent);
    const std::string pair = r.index <= 5 ? "L1+L2" : "L3+L4";
    char buf[600];
    std::snprintf(
        buf, sizeof buf,
        "F%-3d %-6s %.4f,%.4f,%.5f,%.5f   %.4f,%.4f,%.5f,%.5f   %+.2f,%+.2f,%+.2f,%+.2f   %s,%s,%s   %.3g (%.3g "
        "%%)\n",
        r.index, pair.c_str(), p.mu_n, p.mu_t, p.eta_n, p.eta_t, e.mu_n, e.mu_t, e.eta_n, e.eta_t, em[0], em[1], em[2],
        em[3], SignedPercent(ec[0]).c_str(), SignedPercent(ec[1]).c_str(), SignedPercent(ec[2]).c_str(), r.e_mm,
        r.e_percent);
    std::fputs(buf, stdout);
    std::snprintf(buf, sizeof buf, "F%d,%s,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g", r.index, pair.c_str(),
                  p.mu_n, p.mu_t, p.eta_n, p.eta_t, e.mu_n, e.mu_t, e.eta_n, e.eta_t);
    csv += buf;
    for (double v : {em[0], em[1], em[2], em[3], ec[0], ec[1], ec[2], r.e_mm, r.e_percent}) csv += "," + CsvCell(v);
    csv += "," + FormatFixed(r.seconds, 1) + "\n";
    json.push_back({{"set", "F" + std::to_string(r.index)},
                    {"pair", pair},
                    {"preset", Numbers({p.mu_n, p.mu_t, p.eta_n, p.eta_t})},
                    {"estimate", Numbers({e.mu_n, e.mu_t, e.eta_n, e.eta_t})},
                    {"error_pct", Numbers({em[0], em[1], em[2], em[3]})},
                    {"combination_error_pct",
                     {{"K_mu", NumberOrNull(ec[0])}, {"K_eta", NumberOrNull(ec[1])}, {"v_c", NumberOrNull(ec[2])}}},
                    {"E_mm", NumberOrNull(r.e_mm)},
                    {"E_pct_BL", NumberOrNull(r.e_percent)},
                    {"seconds", NumberOrNull(r.seconds)}});
  }
  std::printf(
      "\nnoise %.3g %% BL: largest |error| of K_mu, K_eta, v_c = %.4g %%; path error mean %.3g %% BL, max %.3g %% BL\n",
      100 * noise, max_comb, rows.empty() ? 0 : sum_e / rows.size(), max_e);
  std::printf(
      "(the four absolute coefficients share one scale that only inertia sets; see the identifiability line "
      "of each estimate, e.g. F%d: %s)\n",
      rows.empty() ? 0 : rows[0].index, rows.empty() ? "" : rows[0].identifiability.c_str());
  if (out.empty()) return Status::Ok();
  WORMDRAG_RETURN_IF_ERROR(WriteFileAtomically(out + "/verify.csv", csv));
  return WriteFileAtomically(out + "/verify.json", Dump(json) + "\n");
}

Result<std::vector<int>> ParseSets(const std::string& list) {
  std::vector<int> which;
  for (const std::string& item : SplitList(list, ',')) {
    long v = 0;
    if (!flags::ToLong(item, &v) || v < 1 || v > 10)
      return Status::InvalidArgument("--sets: values must be whole numbers 1-10, not '" + item + "'");
    which.push_back(static_cast<int>(v));
  }
  return which;
}

}  // namespace

int RunVerify(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"out", "DIR", "also write verify.csv and verify.json there", ""},
      {"noise", "S", "tracking noise on every point, fraction of body length (e.g. 0.005)", "0"},
      {"smoothing", "METHOD",
       "with --noise: smoothing of the noisy recordings, as `estimate` smooths: auto (GCV smoothing spline), "
       "lowpass (the paper's 5 Hz Butterworth) or none",
       "auto"},
      {"seed", "N", "seed of the preset sets F1-F10 (and of the noise)", "2017"},
      {"sets", "LIST", "which of F1-F10 to run, e.g. 1,6", "1,2,3,4,5,6,7,8,9,10"},
      {"threads", "N", "worker threads", "all cores"},
      {"fps", "F", "frame rate of the simulated recordings", "300"},
      {"t-max", "T", "length of the recordings and analysed span, s", "5"},
      {"n-max", "N", "Phase 1 grid size", "10"},
  };
  const std::string usage = Usage(
      "wormdrag verify", "[--out DIR] [--noise S] [options]",
      "The paper's verification (section 3.1): ten preset coefficient sets drawn uniformly from\n"
      "[0,1]^2 x [0,0.01]^2 drive the patterns q_i = A sin(5t - 0.6 i) + b (Locomotion 1-4); the\n"
      "full pipeline estimates them from the simulated paths. The data are made by the same\n"
      "simulator and step the estimator uses, as in the paper. Prints preset vs estimated\n"
      "coefficients, their % errors, the errors of K_mu, K_eta and v_c, and the path error.\n"
      "With --noise, Gaussian tracking noise is added to every point and the recordings are\n"
      "smoothed as `estimate` smooths real data (--smoothing) before estimation.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("verify", args.status());
  auto noise = args->GetDouble("noise", 0), fps = args->GetDouble("fps", 300), tmax = args->GetDouble("t-max", 5);
  auto seed = args->GetIntIn("seed", 2017, 0, std::numeric_limits<long>::max()),
       threads = args->GetIntIn("threads", DefaultThreads(), 1, 4096), nmax = args->GetInt("n-max", 10);
  for (const auto* r : {&noise, &fps, &tmax})
    if (!r->ok()) return Fail("verify", r->status());
  for (const auto* r : {&seed, &threads, &nmax})
    if (!r->ok()) return Fail("verify", r->status());
  if (*noise < 0 || *fps <= 0 || *tmax <= 0)
    return Fail("verify", Status::InvalidArgument("--noise must be >= 0, --fps and --t-max positive"));
  auto which = ParseSets(args->Get("sets", "1,2,3,4,5,6,7,8,9,10"));
  if (!which.ok()) return Fail("verify", which.status());
  auto smoothing = ParseSmoothingMethod(args->Get("smoothing", "auto"));
  if (!smoothing.ok()) return Fail("verify", Status::InvalidArgument("--smoothing: " + smoothing.status().message()));
  VerifySetup v;
  v.noise = *noise;
  v.fps = *fps;
  v.threads = static_cast<int>(*threads);
  v.job.smoothing = *smoothing;
  v.job.estimate.eval.t_max = *tmax;
  v.job.estimate.search.n_max = static_cast<int>(*nmax);
  if (Status st = v.job.estimate.Validate(); !st.ok()) return Fail("verify", st);
  const std::string out = args->Get("out");
  if (!out.empty()) ::mkdir(out.c_str(), 0755);

  const std::vector<Coefficients> F = PresetSets(static_cast<uint64_t>(*seed));
  std::mt19937_64 noise_rng(static_cast<uint64_t>(*seed) + 1);
  std::vector<Row> rows;
  ProgressBar bar(StderrIsTerminal());
  for (int i : *which) {
    auto row = VerifySet(i, F[i - 1], v, &noise_rng, &bar);
    if (!row.ok()) return Fail("verify", row.status().Annotate("F" + std::to_string(i)));
    rows.push_back(*row);
  }
  if (Status st = ReportRows(rows, *noise, out); !st.ok()) return Fail("verify", st);
  return 0;
}

}  // namespace wormdrag::cli
