// Forward sensitivities of the simulated poses with respect to the coefficients
// c = (μ_n, μ_t, η_n, η_t) (see simulator.h). They are computed after the plain run,
// from its knot velocities, in two passes:
//
//  knots: at each knot ξ makes the gradient of the knot objective vanish,
//      K ξ − c_hist + Σ_i J_i f_i(J_i ξ + b_i; c) = 0,
//    so H dξ/dc = dc_hist/dc − Σ_i J_i ∂f_i/∂c with H = K + Σ_i J_i J_iᵀ ∂f_i/∂v, the
//    Hessian at the converged ξ (∂f/∂μ = sgnε(v), ∂f/∂η = v). For the inertial model
//    c_hist is the BDF2 history of the momentum π = M ξ + s and of a = ad*_ξ π, whose
//    sensitivities are carried from the two previous knots.
//  poses: the RK4 step differentiated along the same path (tangent-linear RK4).
//
// Lanes are independent, so a set's sensitivities do not depend on its batch.
#include <algorithm>
#include <cmath>

#include "core/sim/internal/kernel.h"
#include "core/sim/pose_step.h"
#include "core/sim/simulator.h"

namespace wormdrag {
namespace {

using sim_kernel::LaneCoefs;
using sim_kernel::W;

constexpr int kC = 4;  // coefficients, in the order μ_n, μ_t, η_n, η_t

inline size_t DxiIndex(int j, int r, int k) {
  return ((static_cast<size_t>(j) * 3 + r) * kC + k) * W;
}

// Adds the friction terms' Hessian at ξ to H and −Σ_i J_i ∂f_i/∂c to rhs, all lanes.
void AddFriction(const KnotGeometry& g, const LaneCoefs& lc, double eps, const double (*xi)[W], double (*H)[W],
                 double (*rhs)[kC][W]) {
  const double e2 = eps * eps;
  for (int i = 0; i < kNumTerms; ++i) {
    const int d = i & 1;  // 0: tangential, 1: normal
    const int kmu = d ? 0 : 1, keta = d ? 2 : 3;
    const double jx = g.jx[i], jy = g.jy[i], jw = g.jw[i], b = g.b[i];
    const double* mu = lc.mu[d];
    const double* eta = lc.eta[d];
#pragma omp simd
    for (int w = 0; w < W; ++w) {
      const double v = jx * xi[0][w] + jy * xi[1][w] + jw * xi[2][w] + b;
      const double is = 1.0 / std::sqrt(v * v + e2);
      const double sg = v * is;
      const double wt = mu[w] * e2 * is * is * is + eta[w];
      H[0][w] += wt * jx * jx;
      H[1][w] += wt * jx * jy;
      H[2][w] += wt * jx * jw;
      H[3][w] += wt * jy * jy;
      H[4][w] += wt * jy * jw;
      H[5][w] += wt * jw * jw;
      rhs[0][kmu][w] -= jx * sg;
      rhs[1][kmu][w] -= jy * sg;
      rhs[2][kmu][w] -= jw * sg;
      rhs[0][keta][w] -= jx * v;
      rhs[1][keta][w] -= jy * v;
      rhs[2][keta][w] -= jw * v;
    }
  }
}

// Momentum π = M ξ + s, a = ad*_ξ π, and their sensitivities at one knot.
struct History {
  double p[3][W], a[3][W], dp[3][kC][W], da[3][kC][W];
};

void Momentum(const KnotGeometry& g, const double (*xi)[W], const double* dxi, History* h) {
  const auto& M = g.mass;
  for (int w = 0; w < W; ++w) {
    const double x0 = xi[0][w], x1 = xi[1][w], x2 = xi[2][w];
    const double p0 = M[0] * x0 + M[1] * x1 + M[2] * x2 + g.shape_momentum[0];
    const double p1 = M[1] * x0 + M[3] * x1 + M[4] * x2 + g.shape_momentum[1];
    const double p2 = M[2] * x0 + M[4] * x1 + M[5] * x2 + g.shape_momentum[2];
    h->p[0][w] = p0;
    h->p[1][w] = p1;
    h->p[2][w] = p2;
    h->a[0][w] = x2 * p1;
    h->a[1][w] = -x2 * p0;
    h->a[2][w] = -(x0 * p1 - x1 * p0);
    for (int k = 0; k < kC; ++k) {
      const double d0 = dxi[(0 * kC + k) * W + w], d1 = dxi[(1 * kC + k) * W + w], d2 = dxi[(2 * kC + k) * W + w];
      const double q0 = M[0] * d0 + M[1] * d1 + M[2] * d2;
      const double q1 = M[1] * d0 + M[3] * d1 + M[4] * d2;
      const double q2 = M[2] * d0 + M[4] * d1 + M[5] * d2;
      h->dp[0][k][w] = q0;
      h->dp[1][k][w] = q1;
      h->dp[2][k][w] = q2;
      h->da[0][k][w] = d2 * p1 + x2 * q1;
      h->da[1][k][w] = -(d2 * p0 + x2 * q0);
      h->da[2][k][w] = -(d0 * p1 + x0 * q1 - d1 * p0 - x1 * q0);
    }
  }
}

// dξ/dc at every knot ([knot][3][coefficient][lane]) from the knot velocities
// xi_series ([knot][3][lane]), for the first `count` lanes (the others: 0).
void KnotSensitivities(const ShapeDrive& drive, const sim_kernel::Lanes& lanes, int count, const SimOptions& opt,
                       const std::vector<double>& xi_series, std::vector<double>& dxi_series) {
  const auto& knots = drive.knots();
  const int n = static_cast<int>(knots.size());
  const bool inertial = opt.solver == Solver::kInertial;
  dxi_series.resize(static_cast<size_t>(n) * 3 * kC * W);
  History h1{}, h2{};  // knots j−1 and j−2
  for (int j = 0; j < n; ++j) {
    double xi[3][W];
    for (int r = 0; r < 3; ++r)
      for (int w = 0; w < W; ++w) xi[r][w] = xi_series[(static_cast<size_t>(j) * 3 + r) * W + w];
    double H[6][W] = {}, rhs[3][kC][W] = {};
    // Knot 0 and every quasi-static knot solve without the kinetic term, with the
    // stand-in coefficients of singular lanes (as the plain run does).
    const bool kinetic = inertial && j > 0;
    if (kinetic) {
      const sim_kernel::Bdf2 bdf = sim_kernel::Bdf2At(knots, j);
      for (int r = 0; r < 6; ++r)
        for (int w = 0; w < W; ++w) H[r][w] = knots[j].mass[r] / bdf.beta;
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < kC; ++k)
          for (int w = 0; w < W; ++w)
            rhs[r][k][w] = (bdf.alpha1 * h1.dp[r][k][w] - bdf.alpha2 * h2.dp[r][k][w]) / bdf.beta + h1.da[r][k][w] +
                           bdf.extrap * (h1.da[r][k][w] - h2.da[r][k][w]);
    }
    AddFriction(knots[j], kinetic ? lanes.real : lanes.solve, opt.epsilon, xi, H, rhs);
    double* dxi = &dxi_series[DxiIndex(j, 0, 0)];
    for (int w = 0; w < W; ++w) {
      const double hw[6] = {H[0][w], H[1][w], H[2][w], H[3][w], H[4][w], H[5][w]};
      sim_kernel::Cholesky3 l;
      // A singular lane's knot-0 velocity is set to rest, whatever its coefficients.
      const bool ok = w < count && l.Factor(hw) && !(j == 0 && !lanes.singular[w].empty());
      for (int k = 0; k < kC; ++k) {
        const double r3[3] = {rhs[0][k][w], rhs[1][k][w], rhs[2][k][w]};
        double x[3] = {0, 0, 0};
        if (ok) l.Solve(r3, x);
        for (int r = 0; r < 3; ++r) dxi[(r * kC + k) * W + w] = x[r];
      }
    }
    if (inertial) {
      h2 = h1;
      Momentum(knots[j], xi, dxi, &h1);
    }
  }
}

// The tangent of stage i's pose rate: dk for pose sensitivity dg and velocity sensitivity dxi.
inline void RateTangent(const PoseRk4Stages& st, int i, const double dg[3][kC], const double (*dxi)[kC],
                        double dk[3][kC]) {
  const double c = st.c[i], s = st.s[i];
  const double* k = st.k[i];
  for (int q = 0; q < kC; ++q) {
    dk[0][q] = -k[1] * dg[2][q] + c * dxi[0][q] - s * dxi[1][q];
    dk[1][q] = k[0] * dg[2][q] + s * dxi[0][q] + c * dxi[1][q];
    dk[2][q] = dxi[2][q];
  }
}

// The RK4 pose integration of the plain run, with its tangent, for lane w.
void PoseSensitivities(const ShapeDrive& drive, const PoseResets* resets, const std::vector<double>& xi_series,
                       const std::vector<double>& dxi_series, int w, Trajectory* tr) {
  const auto& knots = drive.knots();
  const int n = static_cast<int>(knots.size());
  const int S = drive.substeps();
  tr->sensitivities.resize(drive.num_frames());
  Pose g = drive.initial_pose();
  double dg[3][kC] = {};
  auto store = [&](int fi) {
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < kC; ++k) tr->sensitivities[fi][r][k] = dg[r][k];
  };
  store(0);
  auto load = [&](int j, double x[3], double dx[3][kC]) {
    for (int r = 0; r < 3; ++r) {
      x[r] = xi_series[(static_cast<size_t>(j) * 3 + r) * W + w];
      for (int k = 0; k < kC; ++k) dx[r][k] = dxi_series[DxiIndex(j, r, k) + w];
    }
  };
  size_t next_reset = 0;
  for (int j = 0; j + 1 < n; ++j) {
    const double h = knots[j + 1].t - knots[j].t;
    double x0[3], dx0[3][kC], x1[3], dx1[3][kC], xm[3] = {}, dxm[3][kC] = {};
    load(j, x0, dx0);
    load(j + 1, x1, dx1);
    const MidpointCubic mc = MidpointCubicAt(knots, j);
    // ξ at the midpoint summed as MidpointXi sums it (knot order, m ≤ 4), with dξ/dc.
    const int m = std::min(mc.m, 4);
    for (int a = 0; a < m; ++a) {
      double xa[3], dxa[3][kC];
      load(mc.lo + a, xa, dxa);
      for (int r = 0; r < 3; ++r) {
        xm[r] += mc.weight[a] * xa[r];
        for (int k = 0; k < kC; ++k) dxm[r][k] += mc.weight[a] * dxa[r][k];
      }
    }
    PoseRk4Stages st;
    PoseRk4Step(h, x0, xm, x1, nullptr, &g, &st);
    // The tangent of the step: the same stages, differentiated.
    double d1[3][kC], d2[3][kC], d3[3][kC], d4[3][kC], dt[3][kC];
    auto stage = [&](const double(*dkp)[kC], double f) {
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < kC; ++k) dt[r][k] = dg[r][k] + f * dkp[r][k];
    };
    RateTangent(st, 0, dg, dx0, d1);
    stage(d1, 0.5 * h);
    RateTangent(st, 1, dt, dxm, d2);
    stage(d2, 0.5 * h);
    RateTangent(st, 2, dt, dxm, d3);
    stage(d3, h);
    RateTangent(st, 3, dt, dx1, d4);
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < kC; ++k) dg[r][k] += h / 6 * (d1[r][k] + 2 * d2[r][k] + 2 * d3[r][k] + d4[r][k]);
    if ((j + 1) % S != 0) continue;
    const int fi = (j + 1) / S;
    const int frame = drive.first_frame() + fi;
    if (resets) {
      while (next_reset < resets->frames.size() && resets->frames[next_reset] < frame) ++next_reset;
      if (next_reset < resets->frames.size() && resets->frames[next_reset] == frame) {
        g = drive.MeasuredPose(frame);
        for (auto& row : dg)
          for (double& v : row) v = 0;
      }
    }
    store(fi);
  }
}

}  // namespace

void Simulator::SimulateBatchWithSensitivities(const ShapeDrive& drive, const Coefficients* sets, int count,
                                               const SimOptions& opt, const PoseResets* resets, SimWorkspace& ws,
                                               Trajectory* out) {
  SimulateBatch(drive, sets, count, opt, resets, ws, out);
  sim_kernel::Lanes lanes;
  sim_kernel::MakeLanes(sets, count, &lanes);
  KnotSensitivities(drive, lanes, count, opt, ws.xi, ws.dxi);
  for (int w = 0; w < count; ++w) PoseSensitivities(drive, resets, ws.xi, ws.dxi, w, &out[w]);
}

}  // namespace wormdrag
