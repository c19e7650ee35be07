// The generator families of the benchmark's seed sets (bench.h, Family): which drive a
// set's pairs take, and the conditions each pair of a family set draws.
#include <algorithm>
#include <cmath>
#include <random>

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

Family FamilyOfSet(uint64_t set_seed) {
  if (set_seed >= 200 && set_seed < 300) return Family::kPattern;
  if (set_seed >= 300 && set_seed < 400) return Family::kKymogram;
  if (set_seed >= 400 && set_seed < 500) return Family::kEnvelope;
  return Family::kStandard;
}

const char* FamilyName(Family f) {
  switch (f) {
    case Family::kPattern:
      return "pattern";
    case Family::kKymogram:
      return "kymogram";
    case Family::kEnvelope:
      return "envelope";
    case Family::kStandard:
      break;
  }
  return "standard";
}

const char* SourceName(const Case& c) {
  return c.source == 2 ? "envelope" : c.source == 1 ? "kymogram" : "pattern";
}

double FpsOf(const Case& c, double fps) {
  return c.family == Family::kStandard ? fps : c.fps;
}
double DurationOf(const Case& c, double duration) {
  return c.family == Family::kStandard ? duration : c.duration;
}
double NoiseOf(const Case& c, double noise) {
  return c.family == Family::kStandard ? noise : c.noise;
}

// Effects that act through the Coulomb coefficients only, and so vanish without them.
bool NeedsCoulomb(const std::string& effect) {
  return effect == "stiction" || effect == "lateral_asymmetry";
}

void DrawConditions(Family family, int index, Case* c) {
  c->family = family;
  if (family == Family::kStandard) return;
  std::mt19937_64 rng(c->seed * 7919 + 17);
  std::uniform_real_distribution<double> U(0, 1);
  c->source = family == Family::kPattern ? 0 : family == Family::kKymogram ? 1 : 2;
  c->fps = std::round(30 * std::pow(10.0, U(rng)));
  c->duration = std::round(10 * (2 + 8 * U(rng))) / 10;
  if (family == Family::kKymogram) c->duration = std::min(c->duration, 9.0);
  c->noise = 0.001 + 0.004 * U(rng);
  // Every other pair is viscous, unless its effect needs Coulomb friction to act.
  if (index % 2 == 1 && !NeedsCoulomb(c->effect)) {
    c->regime = "viscous";
    const double eta_t = 0.001 + 0.004 * U(rng);
    c->coef = Coefficients{0, 0, eta_t * (1.5 + 2.5 * U(rng)), eta_t};
  }
  for (JointPattern& w : c->waves) {
    w.amplitude = 0.3 + 0.4 * U(rng);
    w.offset = 0.2 * U(rng) - 0.1;
    w.omega = 3 + 5 * U(rng);
    w.wavenumber = 0.4 + 0.4 * U(rng);
    w.envelope_depth = 0.2 + 0.4 * U(rng);
    w.envelope_hz = 0.1 + 0.4 * U(rng);
    w.envelope_phase = 2 * M_PI * U(rng);
  }
}

}  // namespace wormdrag::diagnose_bench
