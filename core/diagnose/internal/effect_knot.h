// The knot solver of the effect-aware simulator (effect_knot.cc): the head-frame
// velocity ξ that balances the friction (and any external wrench) at one knot. Private
// to core/diagnose; effect_sim.h exposes it per coefficient set (SolveEffectKnot).
#pragma once

#include <array>

#include "core/diagnose/effects.h"
#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"

namespace wormdrag::diagnose::effect_knot {

// Per-term coefficients at time fraction tau: base × body_gradient (× time_drift on the
// normal terms).
void TermCoefficients(const Coefficients& c, const EffectParams& p, double tau, double mu[kNumTerms],
                      double eta[kNumTerms]);

// ξ (in: the warm start, out: the solution) with per-term coefficients mu, eta; false
// if the tolerance was not met. `iterations` counts Newton iterations.
bool SolveKnot(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
               const std::array<double, 3>& ext, double L, double tol, int max_it, std::array<double, 3>* xi,
               long* iterations);

}  // namespace wormdrag::diagnose::effect_knot
