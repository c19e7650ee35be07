// --null-truth-check: which truth makes the noise-only replicates right? On the `none`
// pairs of a seed set (two noise draws each), the p-values of the TRUE model's full-path
// and blocked scores on the data among replicates made as the diagnosis makes them: E by
// rank, and log MSE by the Student-t prediction the verdict uses (decision 0039) (the
// truth simulated on prepared shapes, tracking noise added, prepared again), for each
// truth of --truths:
//   data      the data prepared (what the diagnosis used before decision 0038);
//   data*K    the data prepared with the smoothing spline's λ × K (--smoothing auto);
//   clean     the noise-free recording prepared (unavailable on real data);
//   shapes    the data's prepared shapes on the clean recording's poses;
//   poses     the clean recording's shapes on the data's prepared poses;
//   periodic  the data's prepared shapes replaced by a fitted periodic gait;
//   gait      the diagnosis's: periodic where the gait explains the shapes down to
//             the noise, the data's prepared shapes elsewhere (NullTruth).
// docs/diagnose.md, "How far the null is from right".
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <map>

#include "bench/diagnose/bench.h"
#include "core/common/format.h"
#include "core/common/stats.h"
#include "core/common/svg.h"
#include "core/model/body.h"

namespace wormdrag::diagnose_bench {
namespace {

// A pair whose frames take their shapes from `shapes` and their poses and link lengths
// from `poses` (prepared recordings of the same frames).
std::array<Kinematics, 2> Hybrid(const EffectData& shapes, const EffectData& poses) {
  std::array<Kinematics, 2> out;
  for (int j = 0; j < 2; ++j) {
    out[j] = poses.worms[j].FullRate();
    const Kinematics& s = shapes.worms[j].FullRate();
    out[j].frames.resize(std::min(out[j].frames.size(), s.frames.size()));
    for (size_t f = 0; f < out[j].frames.size(); ++f) {
      Frame& fr = out[j].frames[f];
      fr.valid = fr.valid && s.frames[f].valid;
      if (!fr.valid) continue;
      const double l = MeanLinkLength(fr.p);
      fr.p = LabPoints(BestFitPose(fr.p, ShapeOf(fr.p), l), ShapeOf(s.frames[f].p), l);
    }
  }
  return out;
}

// Whether truth `truth` is made from the clean recording.
bool NeedsClean(const std::string& truth) {
  return truth == "clean" || truth == "shapes" || truth == "poses";
}

// The prepared truth named `truth` for one draw; `clean` is the prepared clean recording
// (nullptr when no truth of --truths needs it).
Result<EffectData> TruthOf(const std::string& truth, const std::array<Kinematics, 2>& noisy, const EffectData* clean,
                           const EffectData& data, const DiagnoseOptions& o) {
  if (truth == "data") return data;
  if (truth.rfind("data*", 0) == 0) {
    DiagnoseOptions so = o;
    so.spline.lambda_scale = std::atof(truth.c_str() + 5);
    return PrepareForDiagnosis(noisy, so);
  }
  if (truth == "clean") return *clean;
  // Already prepared: put together as they are.
  DiagnoseOptions as_is = o;
  as_is.smoothing = SmoothingMethod::kNone;
  if (truth == "shapes") return PrepareForDiagnosis(Hybrid(data, *clean), as_is);
  if (truth == "poses") return PrepareForDiagnosis(Hybrid(*clean, data), as_is);
  std::array<double, 2> excess;
  auto gait = [&](double max_excess) {
    auto t = NullTruth(noisy, data, o, max_excess, &excess);
    std::printf(" excess %.2f %.2f", excess[0], excess[1]);
    return t;
  };
  if (truth == "periodic") return gait(INFINITY);
  if (truth == "gait") return gait(kMaxGaitExcess);
  return Status::InvalidArgument("unknown truth '" + truth + "'");
}

// A truth of --truths in words (the QQ plot's legend).
std::string Described(const std::string& truth) {
  if (truth == "data") return "the data's shapes";
  if (truth == "shapes") return "the data's shapes, clean poses";
  if (truth == "poses") return "clean shapes, the data's poses";
  if (truth == "clean") return "the clean recording";
  if (truth == "periodic") return "a periodic gait fitted to the data's shapes";
  if (truth == "gait") return "the diagnosis's (NullTruth)";
  return truth;
}

// The drives and friction regimes the p-values are grouped by (SourceName, Case::regime).
const char* const kDrives[] = {"pattern", "kymogram", "envelope"};
const char* const kRegimes[] = {"coulomb", "viscous"};

// The full-path p-values of each truth and drive against the uniform's quantiles: the
// verdict's own (the data's log MSE against the replicates' Student-t prediction).
std::string QqPlot(const std::map<std::string, std::vector<double>>& p, const std::vector<std::string>& truths,
                   int reps) {
  svg::PlotSpec plot;
  plot.title = "Full-path gap test on none pairs: p-value quantiles (" + std::to_string(reps) + " replicates)";
  plot.x.label = "uniform quantile";
  plot.y.label = "p-value of the data's full-path MSE (Student-t on log, as the verdict tests)";
  plot.x.lo = plot.y.lo = 0;
  plot.x.hi = plot.y.hi = 1;
  plot.series.push_back({{0, 1}, {0, 1}, "#888888", 1, "4,3", "right null"});
  const char* colors[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  int k = 0;
  for (const std::string& truth : truths) {
    for (size_t drive = 0; drive < std::size(kDrives); ++drive)
      for (const char* regime : kRegimes) {
        const std::string group = std::string(kDrives[drive]) + " " + regime;
        auto it = p.find(truth + " full path t, " + group);
        if (it == p.end()) continue;
        std::vector<double> v = it->second;
        std::sort(v.begin(), v.end());
        svg::Series s;
        for (size_t i = 0; i < v.size(); ++i) {
          s.x.push_back((i + 0.5) / v.size());
          s.y.push_back(v[i]);
        }
        s.color = colors[(3 * k + drive) % 6];
        s.dash = std::string(regime) == "viscous" ? "6,3" : "";
        s.markers = true;
        s.label = (truths.size() > 1 ? "truth: " + Described(truth) + ", " : std::string()) + group;
        plot.series.push_back(std::move(s));
      }
    ++k;
  }
  return svg::RenderPlot(plot);
}

}  // namespace

double RankPValue(double data, const std::vector<double>& reps) {
  double above = 1;
  for (double r : reps) above += r >= data;
  return above / (reps.size() + 1);
}

void PrintPValueShares(const std::string& name, std::vector<double> v) {
  if (v.empty()) return;
  std::sort(v.begin(), v.end());
  double ks = 0;
  for (size_t i = 0; i < v.size(); ++i)
    ks = std::max({ks, std::abs(v[i] - double(i) / v.size()), std::abs(v[i] - double(i + 1) / v.size())});
  auto share = [&](double q) { return double(std::upper_bound(v.begin(), v.end(), q + 1e-12) - v.begin()) / v.size(); };
  std::printf("  %-22s %2zu draws: <= 0.05: %.2f, <= 0.1: %.2f, <= 0.5: %.2f; KS %.2f; sorted", name.c_str(), v.size(),
              share(0.05), share(0.1), share(0.5), ks);
  for (double p : v) std::printf(" %.2f", p);
  std::printf("\n");
}

int NullTruthCheck(const Bench& b) {
  const flags::Args& args = b.args;
  const DiagnoseOptions& options = b.o;
  std::vector<Case> cases;
  for (const std::string& set : SplitList(ArgS(args, "--set", "11"))) {
    const auto more = MakeCases(std::strtoull(set.c_str(), nullptr, 10));
    cases.insert(cases.end(), more.begin(), more.end());
  }
  const double noise = Arg(args, "--noise", 0.002);
  const int reps = std::max(2, static_cast<int>(Arg(args, "--reps", 3)));
  const std::vector<std::string> truths = SplitList(ArgS(args, "--truths", "data,clean"));
  for (const std::string& t : truths)
    if (!(t == "data" || t.rfind("data*", 0) == 0 || NeedsClean(t) || t == "periodic" || t == "gait")) {
      std::fprintf(stderr, "--truths: unknown truth '%s' (data, data*K, clean, shapes, poses, periodic, gait)\n",
                   t.c_str());
      return 2;
    }
  const bool needs_clean = std::any_of(truths.begin(), truths.end(), NeedsClean);
  // p-values per truth, statistic (full path, blocked) and drive.
  std::map<std::string, std::vector<double>> p;
  for (const Case& c : cases) {
    if (c.category != "none") continue;
    const std::string source = SourceName(c);
    DiagnoseOptions o = options;
    o.t_max = DurationOf(c, b.duration);
    const double sigma = NoiseOf(c, noise);
    // The clean recording is the same for both noise draws.
    Result<EffectData> clean = Status::Internal("not needed");
    if (needs_clean) {
      auto k = Synth(c, b.src, b.fps, b.duration, 0.0);
      if (!k.ok()) continue;
      clean = PrepareForDiagnosis(*k, o);
      if (!clean.ok()) continue;
    }
    for (uint64_t draw : {uint64_t{0}, uint64_t{1000003}}) {
      auto noisy = Synth(c, b.src, b.fps, b.duration, sigma, draw);
      if (!noisy.ok()) continue;
      auto d = PrepareForDiagnosis(*noisy, o);
      if (!d.ok()) continue;
      double full_mse = 0, blocked_mse = 0;
      const double full = TrueModelE(*d, c, o.epsilon, &full_mse, false),
                   blocked = TrueModelE(*d, c, o.epsilon, &blocked_mse);
      std::printf("| %d%s | %s %s, %g fps, %g s, %.1f um |", static_cast<int>(c.seed), draw ? "b" : "a", source.c_str(),
                  c.regime.c_str(), FpsOf(c, b.fps), o.t_max, 1e3 * sigma);
      for (const std::string& truth : truths) {
        auto t = TruthOf(truth, *noisy, clean.ok() ? &*clean : nullptr, *d, o);
        if (!t.ok()) {
          std::fprintf(stderr, "%s\n", t.status().ToString().c_str());
          return 2;
        }
        // E for the rank p-values; log MSE for the verdict's own (decision 0039).
        std::vector<double> rf, rb, lf, lb;
        for (int r = 1; r <= reps; ++r) {
          auto rec = NullPair(*t, c.coef, o.epsilon, sigma, r + (draw ? 100 : 0));
          if (!rec.ok()) continue;
          auto y = PrepareForDiagnosis(*rec, o);
          if (!y.ok()) continue;
          double mf = 0, mb = 0;
          rf.push_back(TrueModelE(*y, c, o.epsilon, &mf, false));
          rb.push_back(TrueModelE(*y, c, o.epsilon, &mb));
          lf.push_back(std::log(mf));
          lb.push_back(std::log(mb));
        }
        if (rf.empty()) continue;
        const double pf = RankPValue(full, rf), pb = RankPValue(blocked, rb);
        const double tf = PredictionPValue(lf, std::log(full_mse)), tb = PredictionPValue(lb, std::log(blocked_mse));
        for (const std::string& group : {std::string("all"), source, c.regime, source + " " + c.regime}) {
          p[truth + " full path, " + group].push_back(pf);
          p[truth + " blocked, " + group].push_back(pb);
          p[truth + " full path t, " + group].push_back(tf);
          p[truth + " blocked t, " + group].push_back(tb);
        }
        std::printf(" %s: p %.2f / %.2f, t %.3f / %.3f |", truth.c_str(), pf, pb, tf, tb);
      }
      std::printf("\n");
      std::fflush(stdout);
    }
  }
  std::printf(
      "\np-values among %d replicates (a right null gives uniform ones): the data's E by rank, and (t) its log MSE by "
      "the Student-t prediction, as the verdict tests:\n",
      reps);
  for (const std::string& truth : truths)
    for (const char* stat : {" full path, ", " blocked, ", " full path t, ", " blocked t, "})
      for (const char* drive : {"", kDrives[0], kDrives[1], kDrives[2]})
        for (const char* regime : {"", kRegimes[0], kRegimes[1]}) {
          const std::string d = drive, r = regime;
          const std::string group = d.empty() ? r.empty() ? "all" : r : r.empty() ? d : d + " " + r;
          const std::string key = truth + stat + group;
          if (p.count(key)) PrintPValueShares(key, p[key]);
        }
  const std::string qq = ArgS(args, "--qq", "");
  if (!qq.empty()) {
    CreateParentFolder(qq);
    std::FILE* f = std::fopen(qq.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "%s: cannot write\n", qq.c_str());
      return 1;
    }
    const std::string svg = QqPlot(p, truths, reps);
    std::fwrite(svg.data(), 1, svg.size(), f);
    std::fclose(f);
  }
  return 0;
}

}  // namespace wormdrag::diagnose_bench
