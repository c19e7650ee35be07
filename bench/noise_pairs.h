// The noise benchmark's synthetic pairs (docs/estimation.md, "Noise benchmark"): one
// definition for noise_bench and replicate_bench, so that both study the same pairs.
// Each bench target defines WORMDRAG_SHARED_DIR.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "bench/kymogram_source.h"
#include "core/diagnose/synth.h"
#include "core/sim/pattern.h"

namespace wormdrag::bench {

struct Regime {
  std::string name;
  Coefficients truth;
  std::string determines;  // the combination the regime determines
};

// Agar-like: Coulomb friction dominates at the body's speeds (v_c = 500 mm/s); water-
// like: no Coulomb part; mixed: v_c = 0.5 mm/s, about the links' speed.
inline const std::vector<Regime>& Regimes() {
  static const std::vector<Regime> regimes = {{"agar", {0.6, 0.2, 0.0012, 0.0004}, "K_mu"},
                                              {"water", {0, 0, 0.003, 0.002}, "K_eta"},
                                              {"mixed", {0.006, 0.0015, 0.006, 0.003}, "v_c"}};
  return regimes;
}

inline const Regime* FindRegime(const std::string& name) {
  for (const Regime& r : Regimes())
    if (r.name == name) return &r;
  return nullptr;
}

// The real drive: joint angles of ElegansBot's delta-turn kymogram, low-passed at
// `cutoff_hz` when it is positive. Above about 8 Hz the kymogram holds only its own
// tracking's white jitter (decision record 0043); unfiltered, that jitter drives the
// truth as fast shape motion.
inline Result<Kinematics> RealShapes(double cutoff_hz = 0) {
  const std::string name = "kymogram_delta-turn.npy";
  return KymogramShapes(std::string(WORMDRAG_SHARED_DIR) + "/data/real/elegansbot/" + name, name, cutoff_hz);
}

// Pair `seed` of a regime, driven by the paper's pattern (L1+L2 or L3+L4) or two
// stretches of `real`, with Gaussian noise of `noise_bl` % of the body length drawn
// from `noise_seed` (the benchmark's own pairs use noise_seed = seed).
inline Result<std::array<diagnose::SynthOutput, 2>> SynthesizePair(const Coefficients& truth, const std::string& drive,
                                                                   double noise_bl, int seed, int noise_seed,
                                                                   double fps, double duration,
                                                                   const Kinematics* real) {
  std::array<diagnose::SynthOutput, 2> out;
  for (int w = 0; w < 2; ++w) {
    diagnose::SynthSpec spec;
    spec.coef = truth;
    spec.fps = fps;
    spec.duration = duration;
    spec.noise = noise_bl / 100 * spec.body.length;
    spec.seed = 1000 * static_cast<uint64_t>(noise_seed) + w;
    if (drive == "real") {
      spec.shapes = real;
      spec.shapes_offset = w * 2.0 + 0.25 * (seed % 4);  // two stretches of the same animal
    } else {
      spec.pattern = Locomotion(w + 1 + 2 * (seed % 2));
    }
    auto s = diagnose::Synthesize(spec);
    if (!s.ok()) return s.status();
    out[w] = std::move(*s);
  }
  return out;
}

}  // namespace wormdrag::bench
