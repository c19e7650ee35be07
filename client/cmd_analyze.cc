// wormdrag analyze: the paper's §4 analyses of finished jobs (friction forces,
// trajectories for several coefficient sets, a t-test between two groups of jobs) and
// the travel along and across the body that each set reproduces.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/results_table.h"
#include "core/analysis/forces.h"
#include "core/analysis/job_analysis.h"
#include "core/analysis/progress.h"
#include "core/common/format.h"
#include "core/common/stats.h"
#include "core/estimate/estimator.h"
#include "core/io/kinematics.h"
#include "core/store/job_store.h"

namespace wormdrag::cli {
namespace {

Result<std::vector<int64_t>> ParseJobList(const std::string& text) {
  std::vector<int64_t> ids;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = text.find(',', pos);
    const std::string item = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    auto id = ParseJobId({item}, 0);
    if (!id.ok()) return id.status();
    ids.push_back(*id);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return ids;
}

const char* kScaleNote =
    "note: forces scale with the overall coefficient scale, which the path does not determine (docs/conventions.md "
    "§2):\n"
    "      multiplying all four coefficients by c leaves the path unchanged without inertia and multiplies\n"
    "      every force by c. Absolute forces rest on the link mass alone; their time course, distribution\n"
    "      over the body and ratios between worms at a common scale are what the data support.\n";

// Writes --csv atomically and says so on stderr (what it holds, when given); the exit code.
int WriteCsv(const Args& args, const std::string& csv, const std::string& what = "") {
  Status st = WriteFileAtomically(args.Get("csv"), csv);
  if (!st.ok()) return Fail("analyze", st);
  std::fprintf(stderr, "wrote %s%s\n", args.Get("csv").c_str(), what.empty() ? "" : (" (" + what + ")").c_str());
  return 0;
}

int AnalyzeForces(const Args& args, JobStore& store) {
  if (args.positionals().size() != 2)
    return Fail("analyze", Status::InvalidArgument("usage: wormdrag analyze forces ID [--coef C] [--csv OUT]"));
  auto id = ParseJobId(args.positionals(), 1);
  if (!id.ok()) return Fail("analyze", id.status());
  auto job = LoadDoneJob(store, *id);
  if (!job.ok()) return Fail("analyze", job.status());
  Coefficients c = job->estimate;
  if (args.Has("coef")) {
    auto parsed = ParseCoefficients(args.Get("coef"));
    if (!parsed.ok()) return Fail("analyze", parsed.status());
    c = *parsed;
  }
  std::printf("job %lld: friction forces with mu_n = %.6g uN, mu_t = %.6g uN, eta_n = %.6g, eta_t = %.6g uN.s/mm%s\n",
              static_cast<long long>(*id), c.mu_n, c.mu_t, c.eta_n, c.eta_t, args.Has("coef") ? "" : " (the estimate)");
  std::printf("%-5s %-8s %-14s %-16s %-14s %-14s %-12s\n", "WORM", "FRAMES", "RMS|f_k| uN", "mean sum|f_k| uN",
              "mean thrust uN", "RMS |net| uN", "power nW");
  std::string csv;
  for (int j = 0; j < 2; ++j) {
    const auto& w = job->pair->worm(j);
    auto f = ComputeLinkForces(w.drive, c, job->pair->options().sim, &w.resets);
    if (!f.ok()) return Fail("analyze", f.status());
    std::printf("%-5d %-8zu %-14.5g %-16.5g %-14.5g %-14.5g %-12.5g\n", j + 1, f->t.size(), f->rms_link,
                f->mean_magnitude_sum, f->mean_thrust, f->rms_net, f->mean_power);
    std::string part = LinkForcesCsv(*f);
    // Prefix each row with the worm number.
    std::string rows;
    size_t pos = 0;
    bool header = true;
    while (pos < part.size()) {
      const size_t nl = part.find('\n', pos);
      const std::string line = part.substr(pos, nl - pos);
      if (header) {
        if (j == 0) rows += "worm," + line + "\n";
        header = false;
      } else
        rows += std::to_string(j + 1) + "," + line + "\n";
      pos = nl + 1;
    }
    csv += rows;
  }
  std::printf(
      "RMS|f_k|: over links and frames; thrust: the links' force components along the direction of travel;\n"
      "net: the force summed over the body (= rate of change of momentum, ~0: propulsion balances drag).\n%s",
      kScaleNote);
  if (args.Has("csv")) {
    if (int rc = WriteCsv(args, csv, "per frame and link: lab-frame force, tangential and normal components"))
      return rc;
  }
  return 0;
}

// The finished job named by the one positional after the analysis's name, and the
// coefficient sets to simulate: its estimate, the sets in `fixed`, then every --coef.
struct JobAndSets {
  LoadedJob job;
  std::vector<Coefficients> sets;
  int64_t id = 0;
};
Result<JobAndSets> LoadJobAndSets(const Args& args, JobStore& store, const std::vector<std::string>& coefs,
                                  const std::string& usage, const std::vector<Coefficients>& fixed) {
  if (args.positionals().size() != 2) return Status::InvalidArgument("usage: " + usage);
  auto id = ParseJobId(args.positionals(), 1);
  if (!id.ok()) return id.status();
  auto job = LoadDoneJob(store, *id);
  if (!job.ok()) return job.status();
  JobAndSets out{std::move(*job), {}, *id};
  out.sets = {out.job.estimate};
  out.sets.insert(out.sets.end(), fixed.begin(), fixed.end());
  for (const auto& text : coefs) {
    auto c = ParseCoefficients(text);
    if (!c.ok()) return Status::InvalidArgument("--coef " + text + ": " + c.status().message());
    out.sets.push_back(*c);
  }
  return out;
}

int AnalyzeTrajectories(const Args& args, JobStore& store, const std::vector<std::string>& coefs) {
  auto loaded = LoadJobAndSets(args, store, coefs, "wormdrag analyze trajectories ID --coef C [--coef C …]", {});
  if (!loaded.ok()) return Fail("analyze", loaded.status());
  const std::vector<Coefficients>& sets = loaded->sets;
  const PairedPath& pair = *loaded->job.pair;
  auto tr = CompareCoefficientSets(pair, sets);
  if (!tr.ok()) return Fail("analyze", tr.status());
  const double L = tr->body_length;
  std::printf("job %lld: the same measured joint angles driven with %zu coefficient sets (set 0 = the estimate)\n",
              static_cast<long long>(loaded->id), sets.size());
  std::printf("%-4s %-36s %-10s %-10s %-12s %-12s %-22s %s\n", "SET", "mu_n,mu_t,eta_n,eta_t", "E mm", "E %BL",
              "worm1 %BL", "worm2 %BL", "from set 0: mm (%BL)", "K_mu K_eta v_c");
  // A ratio of two zero coefficients is undefined; one over zero is infinite.
  auto ratio = [](double v) { return std::isnan(v) ? std::string("undefined") : FormatNumber(v, 4); };
  for (size_t i = 0; i < sets.size(); ++i) {
    const auto& c = sets[i];
    std::printf("%-4zu %-36s %-10.4g %-10.4g %-12.4g %-12.4g %-9.4g (%-8.4g)    %s %s %s\n", i, c.ToString().c_str(),
                tr->e_mm[i], 100 * tr->e_mm[i] / L, 100 * tr->e_mm_worm[i][0] / L, 100 * tr->e_mm_worm[i][1] / L,
                tr->distance_to_first_mm[i], 100 * tr->distance_to_first_mm[i] / L, ratio(c.K_mu()).c_str(),
                ratio(c.K_eta()).c_str(), ratio(c.v_c()).c_str());
  }
  std::printf(
      "Sets with the same K_mu, K_eta and v_c (one a multiple of another) give the same path up to the tiny\n"
      "effect of inertia (docs/conventions.md §2); sets that differ in those combinations give different paths.\n");
  if (args.Has("csv")) {
    std::string csv = "set,worm,t,point,measured_x,measured_y,simulated_x,simulated_y\n";
    char buf[200];
    const auto& pts = pair.options().points;
    for (size_t i = 0; i < sets.size(); ++i)
      for (int j = 0; j < 2; ++j)
        for (size_t f = 0; f < tr->paths[i].t[j].size(); ++f)
          for (size_t p = 0; p < pts.size(); ++p) {
            const auto& m = tr->paths[i].measured[j][f][p];
            const auto& s = tr->paths[i].simulated[j][f][p];
            std::snprintf(buf, sizeof buf, "%zu,%d,%.6f,%d,%.9g,%.9g,%.9g,%.9g\n", i, j + 1, tr->paths[i].t[j][f],
                          pts[p], m.x(), m.y(), s.x(), s.y());
            csv += buf;
          }
    if (int rc = WriteCsv(args, csv)) return rc;
  }
  return 0;
}

// "12.3 ± 4.5" in µm/s, with the p-value of a zero mean when asked; one stretch's value
// alone.
std::string MeanText(const ProgressMean& m, bool with_p) {
  char buf[80];
  if (m.n < 1) return "-";
  if (m.n == 1) return FormatNumber(1e3 * m.mean, 3);
  std::snprintf(buf, sizeof buf, "%.3g ± %.2g", 1e3 * m.mean, 1e3 * m.se);
  std::string s = buf;
  if (with_p && std::isfinite(m.p_zero)) s += " (p " + FormatNumber(m.p_zero, 2) + ")";
  return s;
}

int AnalyzeProgress(const Args& args, JobStore& store, const std::vector<std::string>& coefs) {
  auto loaded = LoadJobAndSets(args, store, coefs, "wormdrag analyze progress ID [--coef C …]", {StillBody()});
  if (!loaded.ok()) return Fail("analyze", loaded.status());
  const std::vector<Coefficients>& sets = loaded->sets;
  auto pr = CompareProgress(*loaded->job.pair, sets);
  if (!pr.ok()) return Fail("analyze", pr.status());
  std::printf(
      "job %lld: travel of the evaluation points per stretch (each simulated stretch starts from the measured\n"
      "pose), um/s, mean ± standard error over a worm's stretches. along: toward the head along the stretch's\n"
      "mean body axis; side: that axis turned +90 deg in the recordings' x-y axes. missed: measured minus\n"
      "simulated, with the p-value of no difference (Student's t over the stretches).\n",
      static_cast<long long>(loaded->id));
  std::printf("%-26s %-5s %-9s %-16s %-16s %-28s %s\n", "SET", "WORM", "STRETCHES", "ALONG", "SIDE", "MISSED ALONG",
              "MISSED SIDE");
  for (int j = 0; j < 2; ++j) {
    std::vector<double> along, side;
    for (const auto& s : pr->stretches)
      if (s.worm == j) along.push_back(s.measured_along), side.push_back(s.measured_side);
    std::printf("%-26s %-5d %-9zu %-16s %-16s\n", "measured", j + 1, along.size(),
                MeanText(MeanOverStretches(along), false).c_str(), MeanText(MeanOverStretches(side), false).c_str());
    for (size_t i = 0; i < sets.size(); ++i) {
      std::vector<double> a, s, ma, ms;
      for (const auto& st : pr->stretches) {
        if (st.worm != j) continue;
        a.push_back(st.along[i]);
        s.push_back(st.side[i]);
        ma.push_back(st.measured_along - st.along[i]);
        ms.push_back(st.measured_side - st.side[i]);
      }
      const std::string name = i == 0 ? "0 (the estimate)" : i == 1 ? "1 (the still body)" : std::to_string(i);
      std::printf("%-26s %-5d %-9zu %-16s %-16s %-28s %s\n", name.c_str(), j + 1, a.size(),
                  MeanText(MeanOverStretches(a), false).c_str(), MeanText(MeanOverStretches(s), false).c_str(),
                  MeanText(MeanOverStretches(ma), true).c_str(), MeanText(MeanOverStretches(ms), true).c_str());
    }
  }
  const size_t per_worm = pr->stretches.size() / 2;
  if (per_worm < 2)
    std::printf(
        "One stretch per worm: its travel, no spread. For a mean over stretches estimate with --restart-every S\n"
        "(or --restart-after-gaps on a recording with gaps).\n");
  if (args.Has("csv")) {
    std::string csv = "set,worm,t0,t1,measured_along,measured_side,simulated_along,simulated_side\n";
    char buf[200];
    for (size_t i = 0; i < sets.size(); ++i)
      for (const auto& st : pr->stretches) {
        std::snprintf(buf, sizeof buf, "%zu,%d,%.6f,%.6f,%.9g,%.9g,%.9g,%.9g\n", i, st.worm + 1, st.t0, st.t1,
                      st.measured_along, st.measured_side, st.along[i], st.side[i]);
        csv += buf;
      }
    if (int rc = WriteCsv(args, csv)) return rc;
  }
  return 0;
}

// One value per job for the group comparison.
Result<double> JobMetric(JobStore& store, int64_t id, const std::string& metric) {
  auto job = LoadDoneJob(store, id);
  if (!job.ok()) return job.status();
  const Coefficients& c = job->estimate;
  if (metric == "rms-force") {
    double sum = 0;
    for (int j = 0; j < 2; ++j) {
      const auto& w = job->pair->worm(j);
      auto f = ComputeLinkForces(w.drive, c, job->pair->options().sim, &w.resets);
      if (!f.ok()) return f.status();
      sum += 0.5 * f->rms_link;
    }
    return sum;
  }
  double v = NAN;
  if (metric == "log-K_mu")
    v = std::log10(c.K_mu());
  else if (metric == "log-K_eta")
    v = std::log10(c.K_eta());
  else if (metric == "log-v_c")
    v = std::log10(c.v_c());
  else if (metric == "E-percent")
    v = job->e_percent;
  else
    return Status::InvalidArgument("--metric must be rms-force, log-K_mu, log-K_eta, log-v_c or E-percent, got '" +
                                   metric + "'");
  if (!std::isfinite(v))
    return Status::FailedPrecondition("job " + std::to_string(id) + ": " + metric +
                                      " is not finite (a coefficient estimated as 0); choose another --metric");
  return v;
}

int AnalyzeCompare(const Args& args, JobStore& store) {
  auto ga = args.Require("group-a");
  if (!ga.ok()) return Fail("analyze", ga.status());
  auto gb = args.Require("group-b");
  if (!gb.ok()) return Fail("analyze", gb.status());
  auto ia = ParseJobList(*ga), ib = ParseJobList(*gb);
  if (!ia.ok()) return Fail("analyze", ia.status());
  if (!ib.ok()) return Fail("analyze", ib.status());
  const std::string metric = args.Get("metric", "rms-force");
  std::vector<double> va, vb;
  for (auto [ids, vals, name] : {std::tuple{&*ia, &va, "A"}, std::tuple{&*ib, &vb, "B"}})
    for (int64_t id : *ids) {
      auto v = JobMetric(store, id, metric);
      if (!v.ok()) return Fail("analyze", v.status());
      std::printf("group %s job %-5lld %s = %.6g\n", name, static_cast<long long>(id), metric.c_str(), *v);
      vals->push_back(*v);
    }
  auto r = WelchTTest(va, vb);
  if (!r.ok()) return Fail("analyze", r.status());
  std::printf("group A: n = %d, mean %.6g, sd %.4g\ngroup B: n = %d, mean %.6g, sd %.4g\n", r->a.n, r->a.mean, r->a.sd,
              r->b.n, r->b.mean, r->b.sd);
  std::printf("Welch t-test: t = %.4g, df = %.4g, p (two-sided) = %.4g\n", r->t, r->df, r->p_two_sided);
  if (metric == "rms-force")
    std::printf(
        "rms-force: RMS over links and frames of the friction force per link, mean of the job's two worms (uN,\n"
        "the paper's Fig. 14).\n%s      A difference between groups may be a difference in the unidentified scale;\n"
        "      log-K_mu, log-K_eta and log-v_c (--metric) compare what the data determine.\n",
        kScaleNote);
  return 0;
}

}  // namespace

int RunAnalyze(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"db", "FILE", "SQLite job store (also $WORMDRAG_DB)", "wormdrag.db"},
      {"coef", "MUN,MUT,ETAN,ETAT",
       "forces: a coefficient set instead of the estimate; trajectories, progress: a set to "
       "compare (repeatable)",
       ""},
      {"csv", "OUT.csv", "forces: per frame and link; trajectories: the paths; progress: per stretch", ""},
      {"group-a", "ID,ID,…", "compare: the jobs of group A", ""},
      {"group-b", "ID,ID,…", "compare: the jobs of group B", ""},
      {"metric", "M", "compare: rms-force, log-K_mu, log-K_eta, log-v_c or E-percent", "rms-force"},
  };
  const std::string usage = Usage(
      "wormdrag analyze",
      "forces ID [--csv OUT] | trajectories ID --coef C [--coef C …] | progress ID [--coef C …] |\n"
      "       compare --group-a IDS --group-b IDS",
      "The paper's §4 analyses of finished estimation jobs:\n"
      "  forces        friction force per link and summed over the body over time (Fig. 12)\n"
      "  trajectories  the paths that other coefficient sets give for the same joint angles (Fig. 11, 13)\n"
      "  progress      per stretch, the travel along the body and sideways: measured, the estimate's, the\n"
      "                still body's and any --coef set's, and what each misses\n"
      "  compare       RMS friction force (or an identified combination) between two groups of jobs,\n"
      "                Welch's t-test (Fig. 14)\n"
      "Forces scale with the overall coefficient scale, which the path does not determine (docs/conventions.md §2).",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("analyze", args.status());
  // --coef may repeat (trajectories).
  const std::vector<std::string> coefs = args->GetAll("coef");
  const auto& pos = args->positionals();
  if (pos.empty())
    return Fail("analyze", Status::InvalidArgument("expected forces, trajectories, progress or compare (see --help)"));
  auto store = JobStore::Open(DefaultDbPath(*args));
  if (!store.ok()) return Fail("analyze", store.status());
  if (pos[0] == "forces") {
    if (coefs.size() > 1) return Fail("analyze", Status::InvalidArgument("forces takes at most one --coef"));
    return AnalyzeForces(*args, **store);
  }
  if (pos[0] == "trajectories") {
    if (coefs.empty())
      return Fail("analyze", Status::InvalidArgument("trajectories needs at least one --coef MUN,MUT,ETAN,ETAT"));
    return AnalyzeTrajectories(*args, **store, coefs);
  }
  if (pos[0] == "progress") return AnalyzeProgress(*args, **store, coefs);
  if (pos[0] == "compare") return AnalyzeCompare(*args, **store);
  return Fail("analyze", Status::InvalidArgument("unknown analysis '" + pos[0] +
                                                 "': expected forces, trajectories, progress or compare"));
}

}  // namespace wormdrag::cli
