// Pieces of the simulator kernel shared by the plain run (simulator.cc) and the
// forward-sensitivity run (sensitivity.cc). Internal to core/sim; the pose step they
// share with the diagnosis is core/sim/pose_step.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"
#include "core/sim/simulator.h"

namespace wormdrag::sim_kernel {

constexpr int W = kLanes;

// Velocity of one of the 26 friction terms for one lane.
inline double TermVelocity(const KnotGeometry& g, int i, const double* xi) {
  return g.jx[i] * xi[0] + g.jy[i] * xi[1] + g.jw[i] * xi[2] + g.b[i];
}

// Cholesky factor of a 3×3 SPD matrix H (upper triangle 00 01 02 11 12 22):
// H = LLᵀ, L = [a 0 0; b d 0; c e f].
struct Cholesky3 {
  double a, b, c, d, e, f;
  // False if H is not numerically positive definite.
  bool Factor(const double* H) {
    if (!(H[0] > 0)) return false;
    a = std::sqrt(H[0]);
    b = H[1] / a;
    c = H[2] / a;
    const double d2 = H[3] - b * b;
    if (!(d2 > 1e-14 * H[3])) return false;
    d = std::sqrt(d2);
    e = (H[4] - b * c) / d;
    const double f2 = H[5] - c * c - e * e;
    if (!(f2 > 1e-14 * H[5])) return false;
    f = std::sqrt(f2);
    return true;
  }
  void Solve(const double* r, double* x) const {
    const double y0 = r[0] / a, y1 = (r[1] - b * y0) / d, y2 = (r[2] - c * y0 - e * y1) / f;
    x[2] = y2 / f;
    x[1] = (y1 - e * x[2]) / d;
    x[0] = (y0 - b * x[1] - c * x[2]) / a;
  }
};

// Solves H x = r; false if H is not numerically positive definite.
inline bool Solve3(const double* H, const double* r, double* x) {
  Cholesky3 l;
  if (!l.Factor(H)) return false;
  l.Solve(r, x);
  return true;
}

struct LaneCoefs {
  double mu[2][W];  // [0]: tangential, [1]: normal
  double eta[2][W];
};

// The coefficients of a batch, lane by lane (idle lanes repeat the last set).
struct Lanes {
  LaneCoefs real;           // the sets themselves
  LaneCoefs solve;          // for quasi-static solves: singular lanes get a harmless stand-in
  std::string singular[W];  // QuasiStaticSingularity of each lane's set
};

inline void MakeLanes(const Coefficients* sets, int count, Lanes* out) {
  for (int w = 0; w < W; ++w) {
    const Coefficients& c = sets[std::min(w, count - 1)];
    out->real.mu[0][w] = c.mu_t;
    out->real.mu[1][w] = c.mu_n;
    out->real.eta[0][w] = c.eta_t;
    out->real.eta[1][w] = c.eta_n;
    out->singular[w] = QuasiStaticSingularity(c);
  }
  // A lane that the quasi-static problem cannot solve gets a stand-in so the batch
  // stays finite; its result is flagged singular (and, inertial, starts at rest).
  out->solve = out->real;
  for (int w = 0; w < W; ++w)
    if (!out->singular[w].empty()) {
      out->solve.mu[0][w] = out->solve.mu[1][w] = 1.0;
      out->solve.eta[0][w] = out->solve.eta[1][w] = 1.0;
    }
}

// Variable-step BDF2 at knot j ≥ 1 (backward Euler at j = 1):
//   π_j − α1 π_{j−1} + α2 π_{j−2} = β π̇_j,
// and the factor of the linear extrapolation a_j ≈ a_{j−1} + extrap (a_{j−1} − a_{j−2}).
struct Bdf2 {
  double alpha1, alpha2, beta, extrap;
};
inline Bdf2 Bdf2At(const std::vector<KnotGeometry>& knots, int j) {
  const double h = knots[j].t - knots[j - 1].t;
  if (j == 1) return {1, 0, h, 0};
  const double r = h / (knots[j - 1].t - knots[j - 2].t);
  return {(1 + r) * (1 + r) / (1 + 2 * r), r * r / (1 + 2 * r), h * (1 + r) / (1 + 2 * r), r};
}

}  // namespace wormdrag::sim_kernel
