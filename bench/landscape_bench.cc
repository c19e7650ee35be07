// E along the ratio a regime determines, with the truth's other coefficients, on a
// synthetic pair processed four ways (docs/estimation.md, "What noise leaves
// undetermined"): where tracking noise moves the minimum, and through which input.
//
//   landscape_bench [--regime agar|water] [--noise 0.5] [--seed 1]
//
// Rows: the clean pair; the noisy pair smoothed as the estimator does (auto); the
// clean shapes driving the model with the smoothed pose and length of the noisy pair
// (the noise reaches only the scored points); the smoothed noisy shapes driving it
// with the clean pose. Columns: E (% BL) at the truth's ratio × the column's factor.
#include <cstdio>
#include <string>
#include <vector>

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

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{"landscape_bench",
                         "[--regime agar|water] [--noise 0.5] [--seed 1]",
                         "E along the ratio a regime determines on a synthetic pair processed four ways\n"
                         "(docs/estimation.md, \"What noise leaves undetermined\").",
                         {{"regime", "agar|water", "the pair's friction regime", "agar"},
                          {"noise", "PCT", "tracking noise, % of the body length", "0.5"},
                          {"seed", "N", "the pair's seed", "1"}},
                         false};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const std::string regime = args.Get("regime", "agar");
  const auto noise_arg = args.GetDouble("noise", 0.5);
  const auto seed_arg = args.GetInt("seed", 1);
  for (const Status& st : {noise_arg.status(), seed_arg.status()})
    if (!st.ok()) return flags::Fail("landscape_bench", st);
  const double noise = *noise_arg;
  const int seed = static_cast<int>(*seed_arg);
  const bool water = regime == "water";
  const Coefficients truth = water ? Coefficients{0, 0, 0.003, 0.002} : Coefficients{0.6, 0.2, 0.0012, 0.0004};
  const std::vector<double> factors = water ? std::vector<double>{0.8, 0.9, 0.95, 1, 1.05, 1.1, 1.33}
                                            : std::vector<double>{0.83, 0.93, 1, 1.33, 2.33, 16.7, 333};
  std::vector<Coefficients> sets;
  for (double f : factors) {
    Coefficients c = truth;
    (water ? c.eta_n : c.mu_n) *= f;
    sets.push_back(c);
  }
  std::array<Kinematics, 2> clean, smoothed, clean_shapes, clean_pose;
  for (int w = 0; w < 2; ++w) {
    diagnose::SynthSpec spec;
    spec.coef = truth;
    spec.noise = noise / 100 * spec.body.length;
    spec.seed = 1000 * seed + w;
    spec.pattern = Locomotion(w + 1 + 2 * (seed % 2));
    auto s = diagnose::Synthesize(spec);
    if (!s.ok()) return std::fprintf(stderr, "%s\n", s.status().ToString().c_str()), 1;
    auto sm = SmoothRecording("worm", s->recording, JobOptions{});
    if (!sm.ok()) return std::fprintf(stderr, "%s\n", sm.status().ToString().c_str()), 1;
    clean[w] = s->clean;
    smoothed[w] = *sm;
    clean_shapes[w] = Combine(s->clean, *sm);
    clean_pose[w] = Combine(*sm, s->clean);
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
  return 0;
}
