// The friction law of docs/conventions.md §1 (binding): Coulomb + viscous, per link, in the link's
// tangential and normal directions, with a smooth sign of width ε.
//
//   f_{k,d} = −μ_d sgnε(v_{k,d}) − η_d v_{k,d},   sgnε(v) = v / sqrt(v² + ε²)
//
// It is the gradient of the convex dissipation potential
//   φ_d(v) = μ_d (sqrt(v² + ε²) − ε) + ½ η_d v².
#pragma once

#include <array>
#include <cmath>
#include <string>

#include "core/common/status.h"

namespace wormdrag {

// Per-link coefficients, always in the order (μ_n, μ_t, η_n, η_t).
// Units: μ in µN, η in µN·s/mm.
struct Coefficients {
  double mu_n = 0, mu_t = 0, eta_n = 0, eta_t = 0;

  std::array<double, 4> AsArray() const { return {mu_n, mu_t, eta_n, eta_t}; }
  static Coefficients FromArray(const std::array<double, 4>& a) { return {a[0], a[1], a[2], a[3]}; }
  Coefficients Scaled(double c) const { return {c * mu_n, c * mu_t, c * eta_n, c * eta_t}; }
  bool operator==(const Coefficients&) const = default;
  std::string ToString() const;  // "0.5,0.2,0.003,0.001"

  // The combinations the data determine (docs/conventions.md §2). NaN where undefined.
  double K_mu() const { return mu_n / mu_t; }
  double K_eta() const { return eta_n / eta_t; }
  double v_c() const { return mu_t / eta_t; }  // crossover speed, mm/s
};

// Parses "MUN,MUT,ETAN,ETAT" (four finite numbers ≥ 0).
Result<Coefficients> ParseCoefficients(const std::string& text);

// Why a coefficient set cannot be simulated without inertia, or "" when it can.
// Without inertia the body's rigid velocity is the minimiser of the dissipation
// potential; it is unique only if every rigid motion dissipates. With no friction
// at all nothing does; with no friction in one direction (μ_d = η_d = 0), a straight
// body slides (tangential) or turns (normal) for free and a bent one is nearly as
// badly conditioned, so such sets are reported instead of silently returned.
std::string QuasiStaticSingularity(const Coefficients& c);

inline constexpr double kDefaultEpsilon = 1e-4;  // mm/s

inline double SmoothSign(double v, double eps) {
  return v / std::sqrt(v * v + eps * eps);
}

}  // namespace wormdrag
