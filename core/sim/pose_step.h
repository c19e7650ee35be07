// The pose integration every simulator of the body shares: core/sim's lanes (the plain
// run and its sensitivities) and the diagnosis' effect-aware simulator
// (core/diagnose/effect_sim.h) step the pose with these functions, so their arithmetic
// is one and the same.
//
// The head-frame velocity ξ = (V_x, V_y, ω) is known at the knots; the pose (x, y, q0)
// follows on SE(2) from (ẋ, ẏ) = R(q0) (V_x, V_y) + w, q̇0 = ω, where w is the lab-frame
// velocity of the medium (absent unless a simulator models a uniform flow). Classical
// RK4 steps from knot to knot, with ξ at the interval's middle from the cubic through up
// to four neighbouring knots (4th order in the knot spacing). Heun's method serves a
// simulator whose ξ at the end of an interval depends on the pose reached there.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/model/body.h"
#include "core/sim/shape_drive.h"

namespace wormdrag {

// Lagrange weights of the value at the midpoint of knots j and j+1 from the cubic (or
// lower) through up to four neighbouring knots: the value is Σ_{a<m} weight[a] ξ[lo + a].
struct MidpointCubic {
  int lo = 0, m = 0;
  double weight[4] = {};
  int last() const { return lo + m - 1; }  // the last knot the cubic reads
};

inline MidpointCubic MidpointCubicAt(const std::vector<KnotGeometry>& knots, int j) {
  const int n = static_cast<int>(knots.size());
  MidpointCubic mc;
  mc.m = std::min(n, 4);
  mc.lo = std::clamp(j - 1, 0, n - mc.m);
  const double t = 0.5 * (knots[j].t + knots[j + 1].t);
  for (int a = mc.lo; a < mc.lo + mc.m; ++a) {
    double wa = 1;
    for (int b = mc.lo; b < mc.lo + mc.m; ++b)
      if (b != a) wa *= (t - knots[b].t) / (knots[a].t - knots[b].t);
    mc.weight[a - mc.lo] = wa;
  }
  return mc;
}

// ξ at the midpoint, where xi(k, r) is component r of ξ at knot k. Each component is
// summed in knot order; stating m ≤ 4 lets the compiler unroll the sum into fused
// multiply-adds (the build enables FMA) rather than vectorise the products and add them
// one by one, which would change the last bit of every pose.
template <class Xi>
inline void MidpointXi(const MidpointCubic& mc, const Xi& xi, double out[3]) {
  const int m = std::min(mc.m, 4);
  for (int r = 0; r < 3; ++r) {
    double sum = 0;
    for (int a = 0; a < m; ++a) sum += mc.weight[a] * xi(mc.lo + a, r);
    out[r] = sum;
  }
}

// Lab-frame rate of the pose (ẋ, ẏ, q̇0) for head-frame velocity ξ, plus the medium's
// velocity w = (w_x, w_y) unless `medium` is null. c and s get cos q0 and sin q0.
inline void PoseRate(const Pose& p, const double* xi, const double* medium, double out[3], double* c_out = nullptr,
                     double* s_out = nullptr) {
  const double c = std::cos(p.q0), s = std::sin(p.q0);
  out[0] = c * xi[0] - s * xi[1];
  out[1] = s * xi[0] + c * xi[1];
  if (medium) {
    out[0] += medium[0];
    out[1] += medium[1];
  }
  out[2] = xi[2];
  if (c_out) *c_out = c;
  if (s_out) *s_out = s;
}

// The four stages of an RK4 pose step, for a step's tangent (sensitivity.cc): the
// heading's cos and sin at each stage's pose and the rate there.
struct PoseRk4Stages {
  double c[4], s[4], k[4][3];
};

// Classical RK4 over one knot interval of length h, with ξ = x0 at its start, xm at its
// middle and x1 at its end; `medium` as for PoseRate. Fills `stages` if given.
inline void PoseRk4Step(double h, const double* x0, const double* xm, const double* x1, const double* medium, Pose* p,
                        PoseRk4Stages* stages = nullptr) {
  double k1[3], k2[3], k3[3], k4[3], c[4], s[4];
  const Pose g = *p;
  PoseRate(g, x0, medium, k1, &c[0], &s[0]);
  PoseRate({g.x + 0.5 * h * k1[0], g.y + 0.5 * h * k1[1], g.q0 + 0.5 * h * k1[2]}, xm, medium, k2, &c[1], &s[1]);
  PoseRate({g.x + 0.5 * h * k2[0], g.y + 0.5 * h * k2[1], g.q0 + 0.5 * h * k2[2]}, xm, medium, k3, &c[2], &s[2]);
  PoseRate({g.x + h * k3[0], g.y + h * k3[1], g.q0 + h * k3[2]}, x1, medium, k4, &c[3], &s[3]);
  p->x = g.x + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
  p->y = g.y + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
  p->q0 = g.q0 + h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]);
  if (stages) {
    const double* k[4] = {k1, k2, k3, k4};
    for (int i = 0; i < 4; ++i) {
      stages->c[i] = c[i];
      stages->s[i] = s[i];
      for (int r = 0; r < 3; ++r) stages->k[i][r] = k[i][r];
    }
  }
}

// Heun's step over one knot interval of length h for a ξ that depends on the pose: ξ = x0
// at the start, and x1_at(pred) returns ξ at the end (a pointer to its three components)
// for the Euler-predicted pose pred there. `medium` as for PoseRate.
template <class EndXi>
inline void PoseHeunStep(double h, const double* x0, const double* medium, const EndXi& x1_at, Pose* p) {
  double k1[3], k2[3];
  const Pose g = *p;
  PoseRate(g, x0, medium, k1);
  const Pose pred{g.x + h * k1[0], g.y + h * k1[1], g.q0 + h * k1[2]};
  PoseRate(pred, x1_at(pred), medium, k2);
  p->x = g.x + 0.5 * h * (k1[0] + k2[0]);
  p->y = g.y + 0.5 * h * (k1[1] + k2[1]);
  p->q0 = g.q0 + 0.5 * h * (k1[2] + k2[2]);
}

}  // namespace wormdrag
