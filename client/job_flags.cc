#include "client/job_flags.h"

#include <cstdio>
#include <cstdlib>
#include <optional>

#include "core/common/format.h"
#include "core/io/frame_quality.h"

namespace wormdrag::cli {

std::vector<Option> JobOptionSpecs() {
  return {
      {"n-max", "N", "Phase 1 grid: N_i = 0 … N per coefficient ((N+1)^4 sets)", "10"},
      {"d-mu", "D", "grid step of the Coulomb coefficients, uN", "0.1"},
      {"d-eta", "D", "grid step of the viscous coefficients, uN.s/mm", "0.001"},
      {"d1", "P", "percent of the grid kept for Phase 2", "1"},
      {"d2", "P", "percent of the refinement kept for Phase 3", "0.2"},
      {"t-max", "T", "analysed span from the first frame, s", "5"},
      {"points", "I,J,K", "evaluation points (joint indices 0-13)", "3,7,10"},
      {"solver", "NAME", "inertial (the paper's model) or quasi-static", "inertial"},
      {"eps", "E", "smooth-sign width of the Coulomb law, mm/s", "1e-4"},
      {"step", "S", "solver knots per frame interval in Phase 3 and the report (0 = 600 knots/s)", "0"},
      {"screening-step", "S", "solver knots per frame interval in Phases 1-2 (0 = 300 knots/s)", "0"},
      {"phase3", "METHOD", "grg, slsqp, lbfgs, bobyqa, neldermead or none", "grg"},
      {"fix-scale", "", "hold the overall coefficient scale in Phase 3 (equality constraint)", ""},
      {"smoothing", "METHOD",
       "shape smoothing: auto (smoothing spline chosen by GCV per recording), lowpass (the paper's Butterworth, "
       "see --lowpass) or none",
       "auto"},
      {"spline-order", "D", "--smoothing auto: order of the penalised differences, 1-6 (2 cubic, 3 quintic)", "3"},
      {"lowpass", "HZ", "Butterworth cut-off for --smoothing lowpass; giving it selects lowpass (0 = none)", "5"},
      {"causal", "", "with lowpass: filter forward only (default: zero phase, forward and backward)", ""},
      {"bootstrap", "N", "bootstrap refits for the 90 % intervals: 0 (no intervals) or at least 19", "20"},
      {"restart-after-gaps", "", "restart the simulated pose from the measured one after missing frames", ""},
      {"restart-every", "S",
       "the paper's swimming protocol: restart the simulated pose from the measured one every S seconds (0 = never)",
       "0"},
      {"full-grid", "", "no early abandoning: every Phase 1-2 set simulated to its end, its E stored (report slices)",
       ""},
  };
}

Result<JobOptions> JobOptionsFromArgs(const Args& a) {
  JobOptions o;
  EstimateOptions& e = o.estimate;
  auto n = a.GetInt("n-max", e.search.n_max);
  if (!n.ok()) return n.status();
  if (*n < 1 || *n > 1000) return Status::InvalidArgument("--n-max must be between 1 and 1000");
  e.search.n_max = static_cast<int>(*n);
  struct D {
    const char* name;
    double* field;
  } doubles[] = {{"d-mu", &e.search.d_mu},
                 {"d-eta", &e.search.d_eta},
                 {"d1", &e.search.d1},
                 {"d2", &e.search.d2},
                 {"t-max", &e.eval.t_max},
                 {"eps", &e.eval.sim.epsilon},
                 {"restart-every", &e.eval.restart_every},
                 {"lowpass", &o.lowpass_hz}};
  for (const auto& d : doubles) {
    auto v = a.GetDouble(d.name, *d.field);
    if (!v.ok()) return v.status();
    *d.field = *v;
  }
  if (o.lowpass_hz < 0) return Status::InvalidArgument("--lowpass must be >= 0 (0 turns filtering off)");
  auto smoothing = ParseSmoothingMethod(a.Get("smoothing", "auto"));
  if (!smoothing.ok()) return Status::InvalidArgument("--smoothing: " + smoothing.status().message());
  o.smoothing = *smoothing;
  if (a.Has("lowpass")) {
    if (a.Has("smoothing") && o.smoothing != SmoothingMethod::kLowpass)
      return Status::InvalidArgument("--lowpass goes with --smoothing lowpass, not " + a.Get("smoothing"));
    o.smoothing = o.lowpass_hz > 0 ? SmoothingMethod::kLowpass : SmoothingMethod::kNone;
  }
  auto order = a.GetInt("spline-order", o.spline.order);
  if (!order.ok()) return order.status();
  o.spline.order = static_cast<int>(*order);
  WORMDRAG_RETURN_IF_ERROR(o.spline.Validate());
  auto replicates = a.GetInt("bootstrap", o.bootstrap.replicates);
  if (!replicates.ok()) return replicates.status();
  o.bootstrap.replicates = static_cast<int>(*replicates);
  WORMDRAG_RETURN_IF_ERROR(o.bootstrap.Validate());
  if (a.Has("points")) {
    e.eval.points.clear();
    for (const std::string& cell : SplitList(a.Get("points"))) {
      char* end = nullptr;
      const long p = std::strtol(cell.c_str(), &end, 10);
      if (cell.empty() || *end != '\0')
        return Status::InvalidArgument("--points: '" + cell + "' is not a point index (0-13)");
      e.eval.points.push_back(static_cast<int>(p));
    }
  }
  auto solver = ParseSolver(a.Get("solver", "inertial"));
  if (!solver.ok()) return solver.status();
  e.eval.sim.solver = *solver;
  auto step = a.GetInt("step", e.eval.substeps), sstep = a.GetInt("screening-step", e.screening_substeps);
  if (!step.ok()) return step.status();
  if (!sstep.ok()) return sstep.status();
  e.eval.substeps = static_cast<int>(*step);
  e.screening_substeps = static_cast<int>(*sstep);
  auto m = ParsePhase3Method(a.Get("phase3", "grg"));
  if (!m.ok()) return m.status();
  e.phase3.method = *m;
  e.phase3.fix_scale = a.Has("fix-scale");
  o.causal_filter = a.Has("causal");
  e.eval.restart_after_gaps = a.Has("restart-after-gaps");
  e.search.abandon = !a.Has("full-grid");
  WORMDRAG_RETURN_IF_ERROR(e.Validate());
  return o;
}

std::vector<Option> InputOptionSpecs() {
  return {{"min-quality", "Q",
           "mark frames missing whose quality in K.quality.csv (beside each K.csv, written by wormdrag track) is below "
           "Q, in [0, 1]; a frame's quality is the overlap of the body re-drawn from its skeleton with the worm's "
           "mask",
           "off"}};
}

Result<std::array<JobInput, 2>> ReadJobInputs(const Args& args) {
  const std::vector<std::string>& paths = args.positionals();
  if (paths.size() != 2)
    return Status::InvalidArgument("expected two recordings K1.csv K2.csv, got " + std::to_string(paths.size()));
  std::optional<double> min_quality;
  if (args.Has("min-quality")) {
    auto q = args.GetDouble("min-quality", 0);
    if (!q.ok()) return q.status();
    if (!(*q >= 0 && *q <= 1)) return Status::InvalidArgument("--min-quality must lie in [0, 1]");
    min_quality = *q;
  }
  std::array<JobInput, 2> in;
  for (int j = 0; j < 2; ++j) {
    auto text = ReadFile(paths[j]);
    if (!text.ok()) return text.status();
    in[j] = {paths[j], std::move(*text)};
    if (!min_quality) continue;
    const std::string qpath = QualityPathFor(paths[j]);
    auto quality = ReadFrameQuality(qpath);
    if (!quality.ok()) return quality.status().Annotate("--min-quality reads the quality file beside " + paths[j]);
    int masked = 0;
    auto kept = MaskLowQualityFrames(in[j].content, paths[j], *quality, qpath, *min_quality, &masked);
    if (!kept.ok()) return kept.status();
    in[j].content = std::move(*kept);
    std::fprintf(stderr, "%s: %d frame(s) with quality below %g marked missing (%s)\n", paths[j].c_str(), masked,
                 *min_quality, qpath.c_str());
  }
  return in;
}

std::string DefaultDbPath(const Args& args) {
  if (args.Has("db")) return args.Get("db");
  if (const char* env = std::getenv("WORMDRAG_DB"); env && *env) return env;
  return "wormdrag.db";
}

}  // namespace wormdrag::cli
