// wormdrag diagnose (the sim-to-real gap: where, which effect, how far) and
// wormdrag synth (synthetic recordings with injected effects and a truth file).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>

#include <nlohmann/json.hpp>

#include "client/cli.h"
#include "client/commands.h"
#include "client/job_flags.h"
#include "client/result_text.h"
#include "core/common/format.h"
#include "core/common/json.h"
#include "core/diagnose/diagnosis.h"
#include "core/diagnose/synth.h"
#include "core/io/kinematics.h"
#include "core/io/kymogram.h"

namespace wormdrag::cli {
namespace {

Result<std::vector<double>> Numbers(const std::string& s, const std::string& what) {
  std::vector<double> v;
  for (const auto& t : SplitList(s, ',')) {
    char* end = nullptr;
    const double x = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !std::isfinite(x))
      return Status::InvalidArgument(what + ": '" + t + "' is not a number");
    v.push_back(x);
  }
  return v;
}

// A kinematics CSV, or a .npy joint-angle kymogram (fps from --kymo-fps).
Result<Kinematics> ReadShapes(const std::string& path, double kymo_fps) {
  if (std::filesystem::path(path).extension() == ".npy") {
    auto a = ReadNpy(path);
    if (!a.ok()) return a.status();
    KymogramOptions ko;
    ko.fps = kymo_fps;
    return KymogramToKinematics(*a, ko, path);
  }
  return ReadKinematics(path);
}

// What every synthetic worm shares: coefficients, effects, noise, knots and gaps.
Result<diagnose::SynthSpec> SynthBase(const Args& a) {
  diagnose::SynthSpec base;
  auto coef = ParseCoefficients(a.Get("coef", "0.5,0.2,0.005,0.002"));
  if (!coef.ok()) return coef.status();
  base.coef = *coef;
  auto eff = diagnose::ParseEffects({a.Get("effect", "none")});
  if (!eff.ok()) return eff.status();
  base.effects = *eff;
  auto noise = a.GetDouble("noise", 0);
  if (!noise.ok()) return noise.status();
  base.noise = *noise;
  auto substeps = a.GetIntIn("substeps", 4, 1, 64);
  if (!substeps.ok()) return substeps.status();
  base.substeps = static_cast<int>(*substeps);
  if (a.Has("gaps")) {
    auto g = Numbers(a.Get("gaps"), "--gaps");
    if (!g.ok() || g->size() != 2 || !((*g)[0] >= 0 && (*g)[0] <= 1e6) || !((*g)[1] >= 0 && (*g)[1] <= 1e6) ||
        (*g)[0] != std::floor((*g)[0]) || (*g)[1] != std::floor((*g)[1]))
      return Status::InvalidArgument("--gaps takes EVERY,LENGTH, whole numbers of frames");
    base.gaps.every = static_cast<int>((*g)[0]);
    base.gaps.length = static_cast<int>((*g)[1]);
  }
  return base;
}

// One spec per worm: the pattern's, or each recording's (read into `sources`, which the
// specs point into), then --fps, --duration, --length and the seeds.
Result<std::vector<diagnose::SynthSpec>> SynthWorms(const Args& a, const diagnose::SynthSpec& base,
                                                    std::vector<Kinematics>* sources) {
  std::vector<diagnose::SynthSpec> worms;
  if (a.Has("pattern")) {
    for (const auto& p : SplitList(a.Get("pattern"), '/')) {
      auto v = Numbers(p, "--pattern");
      if (!v.ok() || v->size() != 2) return Status::InvalidArgument("--pattern takes A,B[/A2,B2]");
      diagnose::SynthSpec s = base;
      s.pattern.amplitude = (*v)[0];
      s.pattern.offset = (*v)[1];
      s.fps = 300;
      s.duration = 5;
      worms.push_back(s);
    }
  } else {
    auto kfps = a.GetDouble("kymo-fps", 32);
    if (!kfps.ok()) return kfps.status();
    const auto paths = SplitList(a.Get("kinematics"), ',');
    auto offsets = Numbers(a.Get("offset", "0"), "--offset");
    if (!offsets.ok()) return offsets.status();
    sources->reserve(paths.size());
    for (size_t i = 0; i < paths.size(); ++i) {
      auto k = ReadShapes(paths[i], *kfps);
      if (!k.ok()) return k.status();
      sources->push_back(std::move(*k));
    }
    for (size_t i = 0; i < paths.size(); ++i) {
      diagnose::SynthSpec s = base;
      s.shapes = &(*sources)[i];
      s.shapes_offset = i < offsets->size() ? (*offsets)[i] : offsets->empty() ? 0 : offsets->back();
      s.fps = (*sources)[i].fps;
      s.duration = (*sources)[i].Duration() - s.shapes_offset;
      s.body.length = (*sources)[i].BodyLength();
      worms.push_back(s);
    }
  }
  if (worms.empty() || worms.size() > 2) return Status::InvalidArgument("one or two worms");
  auto seed = a.GetIntIn("seed", 1, 0, std::numeric_limits<long>::max());
  if (!seed.ok()) return seed.status();
  for (size_t i = 0; i < worms.size(); ++i) {
    auto& s = worms[i];
    for (auto [name, out] : std::initializer_list<std::pair<const char*, double*>>{
             {"fps", &s.fps}, {"duration", &s.duration}, {"length", &s.body.length}}) {
      auto v = a.GetDouble(name, *out);
      if (!v.ok()) return v.status();
      *out = *v;
    }
    s.seed = static_cast<uint64_t>(*seed) + i;
  }
  return worms;
}

// Simulates each worm and writes worm<i>.csv, clean<i>.csv and truth.json into `dir`.
Status WriteSynthetic(const std::vector<diagnose::SynthSpec>& worms, const diagnose::EffectParams& effects,
                      const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Status::InvalidArgument("cannot create " + dir + ": " + ec.message());
  Json truth_worms = Json::array();
  for (size_t i = 0; i < worms.size(); ++i) {
    auto r = diagnose::Synthesize(worms[i]);
    if (!r.ok()) return r.status().Annotate("worm " + std::to_string(i + 1));
    const std::string n = std::to_string(i + 1);
    WORMDRAG_RETURN_IF_ERROR(WriteKinematics(r->recording, dir + "/worm" + n + ".csv"));
    WORMDRAG_RETURN_IF_ERROR(WriteKinematics(r->clean, dir + "/clean" + n + ".csv"));
    truth_worms.push_back(r->truth);
  }
  const Json truth = {{"worms", truth_worms}, {"effects", effects.ToString()}};
  return WriteFileAtomically(dir + "/truth.json", Dump(truth) + "\n");
}

}  // namespace

int RunSynth(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"kinematics", "K.csv[,K2.csv]", "recording(s) whose joint angles drive the body (.csv, or .npy kymogram)", ""},
      {"pattern", "A,B[/A2,B2]", "the paper's pattern q_i = A sin(5t - 0.6 i) + B instead (one or two worms)", ""},
      {"coef", "MUN,MUT,ETAN,ETAT", "friction coefficients per link (uN, uN, uN.s/mm, uN.s/mm)", "0.5,0.2,0.005,0.002"},
      {"effect", "NAME=V[,V2][;NAME=V...]",
       "injected effects: the catalogue (body_gradient, time_drift, power_law, stiction, lag, flow, gap_offset, "
       "lateral_asymmetry) and, out of it, stretch (A: L(t) = L(1 + A sin(2 pi 1.3 t))), tether (k uN/mm: the "
       "centroid pulled back to its start) and boundary (A: friction x (1 + A) beyond the line x = x0 through the "
       "starting centroid)",
       "none"},
      {"noise", "S", "tracking noise: sigma of every point coordinate, mm", "0"},
      {"seed", "N", "random seed of the noise (worm 2 uses N+1)", "1"},
      {"out", "DIR", "output folder: worm1.csv [worm2.csv], clean1.csv [clean2.csv], truth.json", ""},
      {"fps", "F", "output frame rate", "300, or the recording's"},
      {"duration", "S", "seconds to simulate", "5, or what the recording covers"},
      {"offset", "S[,S2]", "with --kinematics: start this many seconds into the recording", "0"},
      {"gaps", "EVERY,LENGTH", "drop LENGTH frames every EVERY frames (needed for gap_offset)", "none"},
      {"length", "MM", "body length", "1, or the recording's"},
      {"kymo-fps", "F", "frame rate of .npy kymograms", "32"},
      {"substeps", "S", "solver knots per frame interval", "4"},
  };
  const std::string usage = Usage(
      "wormdrag synth",
      "(--kinematics K.csv | --pattern A,B) --out DIR [--coef ...] [--effect NAME=V] [--noise S] [--seed N]",
      "Writes synthetic recordings (kinematics CSV) of a body driven by the given joint angles, simulated\n"
      "quasi-statically with effects injected, plus tracking noise and dropped frames, and a separate\n"
      "truth.json with everything that was injected. Two shape sources make a pair for 'diagnose'.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto a = Args::Parse(cmdline, specs);
  if (!a.ok()) return Fail("synth", a.status());
  auto out_dir = a->Require("out");
  if (!out_dir.ok()) return Fail("synth", out_dir.status());
  if (a->Has("kinematics") == a->Has("pattern"))
    return Fail("synth", Status::InvalidArgument("give exactly one of --kinematics and --pattern"));
  auto base = SynthBase(*a);
  if (!base.ok()) return Fail("synth", base.status());
  std::vector<Kinematics> sources;
  auto worms = SynthWorms(*a, *base, &sources);
  if (!worms.ok()) return Fail("synth", worms.status());
  if (Status st = WriteSynthetic(*worms, base->effects, *out_dir); !st.ok()) return Fail("synth", st);
  std::fprintf(stderr, "wrote %zu recording(s) and truth.json to %s (effects: %s)\n", worms->size(), out_dir->c_str(),
               base->effects.ToString().c_str());
  return 0;
}

namespace {

std::vector<Option> DiagnoseFlagSpecs() {
  const diagnose::DiagnoseOptions d;
  std::vector<Option> all = {
      {"json", "OUT.json", "write the full diagnosis as JSON", ""},
      {"report", "OUT.html", "write a self-contained HTML report (inline SVG figures)", ""},
      {"t-max", "S", "analysed span from the first frame (shortened to the recordings)", "5"},
      {"points", "I,J,K", "evaluation points of the fits (joint indices 0-13)", "3,7,10"},
      {"smoothing", "METHOD",
       "smoothing of the recordings: auto (a smoothing spline per shape mode chosen by GCV, as the estimate "
       "smooths; the noise-only null is right only with it), lowpass (the paper's Butterworth of the joint angles, "
       "see --lowpass) or none",
       "auto"},
      {"lowpass", "HZ", "Butterworth cut-off for --smoothing lowpass, zero phase (0 = off)", "5"},
      {"interpolate-gaps", "N", "interpolate runs of <= N missing frames before filtering (they stay unscored)", "0"},
      {"blocks", "B",
       "time blocks per worm for held-out scoring (two folds: even/odd blocks); 0 = one per 0.5 s of the analysed "
       "span, as benchmarked",
       "0"},
      {"null", "R", "noise-only replicates for the null distribution (fewer: faster, but erratic bars)", "8"},
      {"noise-sigma", "MM", "tracking noise per coordinate (default: estimated from the data)", "estimated"},
      {"effects", "A,B,...", "catalogue effects to test", "all eight"},
      {"threads", "N", "worker threads", "all cores"},
      {"no-grid", "", "base fit by GRG from --start instead of the paper's Phases 1-3", ""},
      {"start", "MUN,MUT,ETAN,ETAT", "with --no-grid: start of the base fit", "0.5,0.2,0.005,0.002"},
      {"iterations", "N", "GRG iterations per effect fit", "10"},
      {"cv-ridge", "W",
       "ridge holding the held-out fits near the base (a factor e in one coefficient costs W^2 x the noise's mean "
       "squared distance; 0 = off)",
       "0.5"},
      {"refine-top", "N",
       "how far: the N effects with the best held-out scores are refitted with free coefficients (0 = report the "
       "base-centred fits)",
       "1"},
      {"simex-draws", "N",
       "SIMEX check: the leading effects and the base are refitted on N copies of the data with tracking noise added, "
       "each as on the data; a gain that grows with the noise (a bias of the noisy drive) or vanishes with it (a "
       "chance fit) is not an effect (0 = off)",
       "3"},
      {"no-gap-signature", "",
       "name gap_offset without its mark: by default it is named only where the base residual jumps at the "
       "dropped frames beyond its change elsewhere, its z outside the (1 - A) prediction interval of the noise-only "
       "refits' marks on the fitted a's side (A: --false-alarm-rate; shown under 'where')",
       ""},
      {"false-alarm-rate", "A",
       "share of noise-only pairs called more than noise: every effect's bar compares the data with the (1 - A) "
       "prediction bound of the noise-only refits, and the two gap tests (held-out blocks, full path) with the "
       "(1 - A/2) bound each, so that together they keep A (0 < A < 1)",
       "0.05"},
      {"clear-margin", "M",
       "a named effect is 'clear' when its held-out gain (and its gain extrapolated to no noise) is at least M times "
       "the bar noise-only refits set, else 'tentative'; it changes no verdict",
       "2"},
      {"unestimated", "skip|name",
       "an effect whose fits all left its parameter at a starting value was not estimated: it is never the verdict "
       "(skip) or may be (name; its interval is then the admissible range)",
       d.require_estimated_params ? "skip" : "name"},
      {"fit-hz", "HZ",
       "time resolution of the fits: every round(fps/HZ)-th frame (plus gap borders) is simulated and scored (0 = "
       "every frame)",
       "30"},
      {"substeps", "S", "solver knots per fitted-frame interval", "2"},
      {"eps", "E", "smooth-sign width, mm/s", "1e-4"},
      {"seed", "N", "seed of the null noise and the bootstrap", "20240607"},
  };
  for (const auto& o : InputOptionSpecs()) all.push_back(o);
  all.push_back({"wait", "", "with --server: follow the job and print the diagnosis (else print the job ID)", ""});
  for (const auto& r : RemoteOptionSpecs())
    if (r.name != "db") all.push_back(r);
  return all;
}

// The diagnosis's options from its flags (validated).
Result<diagnose::DiagnoseOptions> DiagnoseOptionsFromArgs(const Args& a) {
  diagnose::DiagnoseOptions o;
  for (auto [name, out] :
       std::initializer_list<std::pair<const char*, double*>>{{"t-max", &o.t_max},
                                                              {"lowpass", &o.lowpass_hz},
                                                              {"noise-sigma", &o.noise_sigma},
                                                              {"eps", &o.epsilon},
                                                              {"fit-hz", &o.fit_hz},
                                                              {"cv-ridge", &o.cv_ridge},
                                                              {"clear-margin", &o.clear_margin},
                                                              {"false-alarm-rate", &o.false_alarm_rate}}) {
    auto v = a.GetDouble(name, *out);
    if (!v.ok()) return v.status();
    *out = *v;
  }
  for (auto [name, out] : std::initializer_list<std::pair<const char*, int*>>{{"blocks", &o.blocks},
                                                                              {"null", &o.null_replicates},
                                                                              {"threads", &o.threads},
                                                                              {"iterations", &o.grg_iterations},
                                                                              {"substeps", &o.substeps},
                                                                              {"interpolate-gaps", &o.interpolate_gaps},
                                                                              {"refine-top", &o.refine_top},
                                                                              {"simex-draws", &o.simex_draws}}) {
    auto v = a.GetIntIn(name, *out, 0, std::numeric_limits<int>::max());
    if (!v.ok()) return v.status();
    *out = static_cast<int>(*v);
  }
  auto seed = a.GetIntIn("seed", static_cast<long>(o.seed), 0, std::numeric_limits<long>::max());
  if (!seed.ok()) return seed.status();
  o.seed = static_cast<uint64_t>(*seed);
  auto smoothing = ParseSmoothingMethod(a.Get("smoothing", SmoothingMethodName(o.smoothing)));
  if (!smoothing.ok()) return Status::InvalidArgument("--smoothing: " + smoothing.status().message());
  o.smoothing = *smoothing;
  if (a.Has("lowpass") && o.smoothing != SmoothingMethod::kLowpass)
    return Status::InvalidArgument("--lowpass goes with --smoothing lowpass, not " +
                                   std::string(SmoothingMethodName(o.smoothing)));
  o.require_gap_signature = !a.Has("no-gap-signature");
  if (a.Has("points")) {
    auto p = Numbers(a.Get("points"), "--points");
    if (!p.ok()) return p.status();
    o.points.clear();
    for (double x : *p) o.points.push_back(static_cast<int>(x));
  }
  if (a.Has("unestimated")) {
    const std::string v = a.Get("unestimated");
    if (v != "skip" && v != "name")
      return Status::InvalidArgument("--unestimated must be skip or name, not '" + v + "'");
    o.require_estimated_params = v == "skip";
  }
  if (a.Has("effects")) o.effects = SplitList(a.Get("effects"), ',');
  if (a.Has("no-grid")) {
    o.base_grid = false;
    auto s = ParseCoefficients(a.Get("start", "0.5,0.2,0.005,0.002"));
    if (!s.ok()) return s.status();
    o.start = *s;
  }
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  return o;
}

// Diagnoses the pair in this process and writes its text, JSON and report.
int DiagnoseEmbedded(const Args& a, const std::array<JobInput, 2>& inputs, diagnose::DiagnoseOptions o) {
  std::array<Kinematics, 2> ks;
  std::array<std::string, 2> names;
  for (int j = 0; j < 2; ++j) {
    names[j] = inputs[j].name;
    auto k = ParseKinematics(inputs[j].content, names[j]);
    if (!k.ok()) return Fail("diagnose", k.status());
    ks[j] = std::move(*k);
  }
  if (StderrIsTerminal()) {
    o.progress = [](const std::string& stage, double f) {
      std::fprintf(stderr, "\r%-40s %5.1f %%", stage.c_str(), 100 * f);
      std::fflush(stderr);
    };
  }
  auto r = diagnose::RunDiagnosis(ks, names, o);
  if (StderrIsTerminal()) std::fputs("\n", stderr);
  if (!r.ok()) return Fail("diagnose", r.status());
  std::fputs(r->ToText().c_str(), stdout);
  if (a.Has("json")) {
    // The same JSON as `results ID --json` of a service diagnosis.
    auto typed = TypedResult("diagnose", r->ToJson());
    if (!typed.ok()) return Fail("diagnose", typed.status());
    Status st = WriteFileAtomically(a.Get("json"), ResultJson(*typed) + "\n");
    if (!st.ok()) return Fail("diagnose", st);
  }
  if (a.Has("report")) {
    Status st = WriteFileAtomically(a.Get("report"), r->ToHtml());
    if (!st.ok()) return Fail("diagnose", st);
  }
  return 0;
}

}  // namespace

int RunDiagnose(const std::vector<std::string>& cmdline) {
  const std::string usage = Usage(
      "wormdrag diagnose", "K1.csv K2.csv [--json OUT] [--report OUT.html] [options]",
      "Diagnoses the sim-to-real gap of a pair of recordings of worms in the same environment: where the\n"
      "base fit's residual lies (vs tracking noise alone), which catalogue effect explains it (each added in\n"
      "turn and scored on held-out time blocks against a noise-only null), and how far held-out E shrinks.\n"
      "Quasi-static solver throughout. Verdict: an effect, 'none', 'unexplained', or 'a|b' (indistinguishable).\n"
      "Record at least 5 s per worm (--t-max analyses the first 5 s): shorter pairs are diagnosed with a caution,\n"
      "since on the benchmark verdicts on 2 s pairs were right far less often (docs/diagnose.md).\n"
      "With --server (or $WORMDRAG_SERVER) it is a job of the wormdrag service: the coordinator runs the base\n"
      "fit, its workers run the effect and null fits; `wormdrag watch/results/cancel ID` follow it.",
      DiagnoseFlagSpecs());
  if (PrintedHelp(cmdline, usage)) return 0;
  auto a = Args::Parse(cmdline, DiagnoseFlagSpecs());
  if (!a.ok()) return Fail("diagnose", a.status());
  if (a->positionals().size() != 2)
    return Fail("diagnose", Status::InvalidArgument("expected two kinematics files K1.csv K2.csv (see --help)"));
  const bool remote = a->Has("server") || std::getenv("WORMDRAG_SERVER");
  if (!remote && a->Has("wait"))
    return Fail("diagnose", Status::InvalidArgument("--wait needs --server (an embedded diagnosis always waits)"));
  auto o = DiagnoseOptionsFromArgs(*a);
  if (!o.ok()) return Fail("diagnose", o.status());
  auto inputs = ReadJobInputs(*a);
  if (!inputs.ok()) return Fail("diagnose", inputs.status());
  if (remote) return SubmitDiagnosisRemote(*a, *inputs, *o);
  return DiagnoseEmbedded(*a, *inputs, *o);
}

}  // namespace wormdrag::cli
