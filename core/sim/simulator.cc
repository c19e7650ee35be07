#include "core/sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/sim/internal/kernel.h"
#include "core/sim/internal/pose_integrator.h"

namespace wormdrag {
namespace {

using sim_kernel::LaneCoefs;
using sim_kernel::Solve3;
using sim_kernel::TermVelocity;
using sim_kernel::W;

// Objective of the per-knot minimisation for one lane: ½ξᵀKξ − cᵀξ + Φ(ξ).
double Objective(const KnotGeometry& g, const double* K, const double* c, const double mu[2], const double eta[2],
                 double eps, const double* xi) {
  double phi = 0;
  for (int i = 0; i < kNumTerms; ++i) {
    const double v = TermVelocity(g, i, xi);
    phi += mu[i & 1] * (std::sqrt(v * v + eps * eps) - eps) + 0.5 * eta[i & 1] * v * v;
  }
  const double kx0 = K[0] * xi[0] + K[1] * xi[1] + K[2] * xi[2];
  const double kx1 = K[1] * xi[0] + K[3] * xi[1] + K[4] * xi[2];
  const double kx2 = K[2] * xi[0] + K[4] * xi[1] + K[5] * xi[2];
  return phi + 0.5 * (xi[0] * kx0 + xi[1] * kx1 + xi[2] * kx2) - (c[0] * xi[0] + c[1] * xi[1] + c[2] * xi[2]);
}

// Damped primal Newton with Armijo backtracking: slow near kinks but monotone, so it
// converges from anywhere on this strictly convex problem. Returns true on success.
bool PrimalNewton(const KnotGeometry& g, const double* K, const double* c, const double mu[2], const double eta[2],
                  double eps, double L, double tol, double* xi, long* iterations) {
  double f = Objective(g, K, c, mu, eta, eps, xi);
  for (int it = 0; it < 200; ++it) {
    ++*iterations;
    double H[6] = {K[0], K[1], K[2], K[3], K[4], K[5]};
    double grad[3] = {K[0] * xi[0] + K[1] * xi[1] + K[2] * xi[2] - c[0],
                      K[1] * xi[0] + K[3] * xi[1] + K[4] * xi[2] - c[1],
                      K[2] * xi[0] + K[4] * xi[1] + K[5] * xi[2] - c[2]};
    for (int i = 0; i < kNumTerms; ++i) {
      const double v = TermVelocity(g, i, xi);
      const double s = std::sqrt(v * v + eps * eps);
      const double fi = mu[i & 1] * v / s + eta[i & 1] * v;
      const double wi = mu[i & 1] * eps * eps / (s * s * s) + eta[i & 1];
      const double j[3] = {g.jx[i], g.jy[i], g.jw[i]};
      for (int r = 0; r < 3; ++r) grad[r] += j[r] * fi;
      H[0] += wi * j[0] * j[0];
      H[1] += wi * j[0] * j[1];
      H[2] += wi * j[0] * j[2];
      H[3] += wi * j[1] * j[1];
      H[4] += wi * j[1] * j[2];
      H[5] += wi * j[2] * j[2];
    }
    double step[3], neg[3] = {-grad[0], -grad[1], -grad[2]};
    if (!Solve3(H, neg, step)) return false;
    const double slope = grad[0] * step[0] + grad[1] * step[1] + grad[2] * step[2];
    double a = 1.0, trial[3];
    for (int ls = 0; ls < 60; ++ls) {
      for (int r = 0; r < 3; ++r) trial[r] = xi[r] + a * step[r];
      const double ft = Objective(g, K, c, mu, eta, eps, trial);
      if (ft <= f + 1e-4 * a * slope || a < 1e-12) {
        f = ft;
        break;
      }
      a *= 0.5;
    }
    for (int r = 0; r < 3; ++r) xi[r] = trial[r];
    if (a * (std::abs(step[0]) + std::abs(step[1]) + std::abs(step[2]) * L) < tol) return true;
  }
  return false;
}

// What the solver did, per lane where it decides whether a lane's run is valid.
struct LaneStats {
  long newton_iterations = 0;  // of the batch
  long fallbacks[W] = {};
  long unconverged[W] = {};
};

// Primal-dual Newton for the lanes in `live` (bit w = lane w) at one knot; the other
// lanes keep their values. K (shared, may be null) and c[3][W] (may be null) define
// the kinetic term. xi[3][W] holds the warm start on entry and the solution on exit;
// lambda[kNumTerms][W] the dual variables. Only lanes 0 … NW−1 are read or written.
template <int NW>
void SolveKnotLanes(const KnotGeometry& g, const double* K, const double (*c)[W], const LaneCoefs& lc, unsigned live,
                    const SimOptions& opt, double L, double (*xi)[W], double (*lambda)[W], LaneStats* stats) {
  const double eps = opt.epsilon, e2 = eps * eps;
  double v[kNumTerms][W], inv_s[kNumTerms][W];
  // A lane stops updating once its own step is below the tolerance, so its result
  // never depends on the other sets that share the batch (bit for bit).
  double active[W];
  int remaining = 0;
  for (int w = 0; w < NW; ++w) {
    active[w] = (live >> w) & 1u ? 1.0 : 0.0;
    remaining += (live >> w) & 1u;
  }
  int it = 0;
  for (; it < opt.max_iterations && remaining > 0; ++it) {
    double H[6][W], grad[3][W];
    for (int r = 0; r < 6; ++r)
      for (int w = 0; w < NW; ++w) H[r][w] = K ? K[r] : 0.0;
    for (int r = 0; r < 3; ++r)
      for (int w = 0; w < NW; ++w) grad[r][w] = c ? -c[r][w] : 0.0;
    if (K) {
#pragma omp simd
      for (int w = 0; w < NW; ++w) {
        grad[0][w] += K[0] * xi[0][w] + K[1] * xi[1][w] + K[2] * xi[2][w];
        grad[1][w] += K[1] * xi[0][w] + K[3] * xi[1][w] + K[4] * xi[2][w];
        grad[2][w] += K[2] * xi[0][w] + K[4] * xi[1][w] + K[5] * xi[2][w];
      }
    }
    for (int i = 0; i < kNumTerms; ++i) {
      const double jx = g.jx[i], jy = g.jy[i], jw = g.jw[i], b = g.b[i];
      const double* mu = lc.mu[i & 1];
      const double* eta = lc.eta[i & 1];
#pragma omp simd
      for (int w = 0; w < NW; ++w) {
        const double vi = jx * xi[0][w] + jy * xi[1][w] + jw * xi[2][w] + b;
        const double is = 1.0 / std::sqrt(vi * vi + e2);
        v[i][w] = vi;
        inv_s[i][w] = is;
        // Newton on the primal gradient, with the curvature μ(1 − λv/s)/s of the
        // primal-dual system in place of the primal μ ε²/s³.
        const double f = mu[w] * vi * is + eta[w] * vi;
        const double wt = mu[w] * (1.0 - lambda[i][w] * vi * is) * is + eta[w];
        grad[0][w] += jx * f;
        grad[1][w] += jy * f;
        grad[2][w] += jw * f;
        H[0][w] += wt * jx * jx;
        H[1][w] += wt * jx * jy;
        H[2][w] += wt * jx * jw;
        H[3][w] += wt * jy * jy;
        H[4][w] += wt * jy * jw;
        H[5][w] += wt * jw * jw;
      }
    }
    double step[3][W];
    bool converged[W];
    for (int w = 0; w < NW; ++w) {
      if (active[w] == 0.0) {  // converged, stopped or idle: a zero step, no solve
        step[0][w] = step[1][w] = step[2][w] = 0;
        continue;
      }
      const double h[6] = {H[0][w], H[1][w], H[2][w], H[3][w], H[4][w], H[5][w]};
      const double r[3] = {-grad[0][w], -grad[1][w], -grad[2][w]};
      double x[3];
      if (!Solve3(h, r, x)) x[0] = x[1] = x[2] = 0;  // singular lane: caught by the caller's checks
      step[0][w] = x[0];
      step[1][w] = x[1];
      step[2][w] = x[2];
      converged[w] = std::abs(x[0]) + std::abs(x[1]) + std::abs(x[2]) * L < opt.velocity_tolerance;
    }
    for (int i = 0; i < kNumTerms; ++i) {
      const double jx = g.jx[i], jy = g.jy[i], jw = g.jw[i];
#pragma omp simd
      for (int w = 0; w < NW; ++w) {
        const double dv = jx * step[0][w] + jy * step[1][w] + jw * step[2][w];
        const double vi = v[i][w], is = inv_s[i][w], lam = lambda[i][w];
        double nl = lam + (vi * is - lam + (1.0 - lam * vi * is) * dv * is);
        nl = nl > 1.0 ? 1.0 : (nl < -1.0 ? -1.0 : nl);
        lambda[i][w] = active[w] != 0.0 ? nl : lam;
      }
    }
    for (int r = 0; r < 3; ++r)
      for (int w = 0; w < NW; ++w) xi[r][w] += step[r][w];
    for (int w = 0; w < NW; ++w)
      if (active[w] != 0.0 && converged[w]) {
        active[w] = 0.0;
        --remaining;
      }
  }
  stats->newton_iterations += it;
  if (remaining == 0) return;
  // Rare: fall back, lane by lane, to the damped primal method for the lanes that did
  // not converge, from their current iterate.
  for (int w = 0; w < NW; ++w) {
    if (active[w] == 0.0) continue;
    ++stats->fallbacks[w];
    double x[3] = {xi[0][w], xi[1][w], xi[2][w]};
    double cw[3] = {c ? c[0][w] : 0.0, c ? c[1][w] : 0.0, c ? c[2][w] : 0.0};
    const double Kz[6] = {0, 0, 0, 0, 0, 0};
    const double mu[2] = {lc.mu[0][w], lc.mu[1][w]}, eta[2] = {lc.eta[0][w], lc.eta[1][w]};
    if (!PrimalNewton(g, K ? K : Kz, cw, mu, eta, eps, L, opt.velocity_tolerance, x, &stats->newton_iterations))
      ++stats->unconverged[w];
    for (int r = 0; r < 3; ++r) xi[r][w] = x[r];
    for (int i = 0; i < kNumTerms; ++i) {
      const double vi = TermVelocity(g, i, x);
      lambda[i][w] = vi / std::sqrt(vi * vi + eps * eps);
    }
  }
}

// SolveKnotLanes on four lanes (one AVX2 vector) when no lane past the fourth is live,
// else on eight: a batch of one to four sets, as Phase 3's steps and line searches
// evaluate, and a Phase 1–2 batch whose last lanes early abandoning has stopped cost
// less (about 10 % for a lone set: the solve is bound by latency, not by the lanes'
// arithmetic). Every lane loop with a multiply-add is an `omp simd` loop, so each lane's
// arithmetic, FMA contractions included, is the same instructions at either width: a
// set's result does not depend on its batch or on when its neighbours stop (tested
// bit for bit).
void SolveKnot(const KnotGeometry& g, const double* K, const double (*c)[W], const LaneCoefs& lc, unsigned live,
               const SimOptions& opt, double L, double (*xi)[W], double (*lambda)[W], LaneStats* stats) {
  if ((live >> (W / 2)) == 0)
    SolveKnotLanes<W / 2>(g, K, c, lc, live, opt, L, xi, lambda, stats);
  else
    SolveKnotLanes<W>(g, K, c, lc, live, opt, L, xi, lambda, stats);
}

// Knots 1 … n−1 of the inertial solver: the body-frame momentum π obeys the
// Euler–Poincaré equations, integrated with variable-step BDF2. `lc` holds the real
// coefficients: with no friction at all the quasi-static stand-ins must not act, and
// the kinetic term keeps such lanes solvable. `store(j)` records knot j and returns
// false when no lane is left.
template <typename Predict, typename Store>
void SolveInertialKnots(const std::vector<KnotGeometry>& knots, const LaneCoefs& lc, const SimOptions& opt, double L,
                        Predict& predict, Store& store, double (*xi)[W], double (*lambda)[W], const unsigned* live,
                        LaneStats* stats) {
  const int n = static_cast<int>(knots.size());
  // Momentum history π_{j-1}, π_{j-2} and gyroscopic terms a = ad*_ξ π.
  double p1[3][W], p2[3][W], a1[3][W], a2[3][W];
  auto momentum = [&](const KnotGeometry& g, double(*p)[W], double(*a)[W]) {
    const auto& M = g.mass;
    for (int w = 0; w < W; ++w) {
      const double x0 = xi[0][w], x1 = xi[1][w], x2 = xi[2][w];
      p[0][w] = M[0] * x0 + M[1] * x1 + M[2] * x2 + g.shape_momentum[0];
      p[1][w] = M[1] * x0 + M[3] * x1 + M[4] * x2 + g.shape_momentum[1];
      p[2][w] = M[2] * x0 + M[4] * x1 + M[5] * x2 + g.shape_momentum[2];
      a[0][w] = x2 * p[1][w];
      a[1][w] = -x2 * p[0][w];
      a[2][w] = -(x0 * p[1][w] - x1 * p[0][w]);
    }
  };
  momentum(knots[0], p1, a1);
  for (int j = 1; j < n; ++j) {
    const auto [alpha1, alpha2, beta, extrap] = sim_kernel::Bdf2At(knots, j);
    double K[6];
    for (int r = 0; r < 6; ++r) K[r] = knots[j].mass[r] / beta;
    double c[3][W];
    for (int r = 0; r < 3; ++r)
      for (int w = 0; w < W; ++w) {
        const double aex = a1[r][w] + extrap * (a1[r][w] - (j == 1 ? a1[r][w] : a2[r][w]));
        c[r][w] = -(knots[j].shape_momentum[r] - alpha1 * p1[r][w] + alpha2 * (j == 1 ? 0.0 : p2[r][w])) / beta + aex;
      }
    predict(j);
    SolveKnot(knots[j], K, c, lc, *live, opt, L, xi, lambda, stats);
    if (!store(j)) return;
    std::copy(&p1[0][0], &p1[0][0] + 3 * W, &p2[0][0]);
    std::copy(&a1[0][0], &a1[0][0] + 3 * W, &a2[0][0]);
    momentum(knots[j], p1, a1);
  }
}

}  // namespace

const char* SolverName(Solver s) {
  return s == Solver::kInertial ? "inertial" : "quasi-static";
}

Result<Solver> ParseSolver(const std::string& name) {
  if (name == "inertial") return Solver::kInertial;
  if (name == "quasi-static" || name == "quasistatic") return Solver::kQuasiStatic;
  return Status::InvalidArgument("unknown solver '" + name + "' (expected inertial or quasi-static)");
}

Status SimOptions::Validate() const {
  if (!(epsilon > 0) || !std::isfinite(epsilon)) return Status::InvalidArgument("eps must be a positive number");
  if (!(velocity_tolerance > 0)) return Status::InvalidArgument("velocity tolerance must be positive");
  if (max_iterations < 1) return Status::InvalidArgument("max iterations must be >= 1");
  return Status::Ok();
}

std::string SimSummary::OneLineReport() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s: %ld knots, %.2f Newton iterations/knot, %ld fallbacks, %ld unconverged%s%s",
                ok() ? "ok" : "FAILED", knots, knots ? double(newton_iterations) / knots : 0.0, fallbacks, unconverged,
                singular.empty() ? "" : ", singular: ", singular.c_str());
  return buf;
}

std::array<double, 3> FrictionWrench(const KnotGeometry& g, const Coefficients& c, double eps,
                                     const std::array<double, 3>& xi) {
  std::array<double, 3> F{0, 0, 0};
  const double mu[2] = {c.mu_t, c.mu_n}, eta[2] = {c.eta_t, c.eta_n};
  for (int i = 0; i < kNumTerms; ++i) {
    const double v = TermVelocity(g, i, xi.data());
    const double f = -mu[i & 1] * SmoothSign(v, eps) - eta[i & 1] * v;
    F[0] += g.jx[i] * f;
    F[1] += g.jy[i] * f;
    F[2] += g.jw[i] * f;
  }
  return F;
}

void Simulator::SimulateBatch(const ShapeDrive& drive, const Coefficients* sets, int count, const SimOptions& opt,
                              const PoseResets* resets, SimWorkspace& ws, Trajectory* out, FrameObserver* observer) {
  const auto& knots = drive.knots();
  const int n = static_cast<int>(knots.size());
  const double L = drive.body().length;
  const bool inertial = opt.solver == Solver::kInertial;
  ws.xi.resize(static_cast<size_t>(n) * 3 * W);

  sim_kernel::Lanes lanes;
  sim_kernel::MakeLanes(sets, count, &lanes);
  const LaneCoefs& lc = lanes.real;
  const LaneCoefs& solve_lc = lanes.solve;
  const std::string* singular = lanes.singular;

  double xi[3][W] = {};
  double lambda[kNumTerms][W];
  for (int i = 0; i < kNumTerms; ++i)
    for (int w = 0; w < W; ++w) lambda[i][w] = SmoothSign(knots[0].b[i], opt.epsilon);

  // Poses follow the velocities knot by knot, so an observer sees each frame as soon
  // as the knots its interval needs are solved.
  PoseIntegrator poses(drive, resets, ws.xi.data(), count, out);
  unsigned live = poses.Start(count, observer);
  LaneStats stats;
  int solved = -1;
  auto store = [&](int j) {
    for (int r = 0; r < 3; ++r)
      for (int w = 0; w < W; ++w) ws.xi[(static_cast<size_t>(j) * 3 + r) * W + w] = xi[r][w];
    solved = j;
    live = poses.Advance(j, live, observer);
    return live != 0;
  };

  // Warm start from the linear extrapolation of the last two knots' solutions.
  auto predict = [&](int j) {
    if (j < 2) return;
    const double r = (knots[j].t - knots[j - 1].t) / (knots[j - 1].t - knots[j - 2].t);
    for (int c = 0; c < 3; ++c)
      for (int w = 0; w < W; ++w) {
        const double a = ws.xi[(static_cast<size_t>(j - 1) * 3 + c) * W + w];
        const double b = ws.xi[(static_cast<size_t>(j - 2) * 3 + c) * W + w];
        xi[c][w] = a + r * (a - b);
      }
  };

  if (live != 0) {
    // Knot 0: the quasi-static velocity (the body is taken to be in steady motion).
    SolveKnot(knots[0], nullptr, nullptr, solve_lc, live, opt, L, xi, lambda, &stats);
    for (int w = 0; w < W; ++w)
      if (!singular[w].empty()) xi[0][w] = xi[1][w] = xi[2][w] = 0;
    if (store(0)) {
      if (!inertial) {
        for (int j = 1; j < n; ++j) {
          predict(j);
          SolveKnot(knots[j], nullptr, nullptr, solve_lc, live, opt, L, xi, lambda, &stats);
          if (!store(j)) break;
        }
      } else {
        SolveInertialKnots(knots, lc, opt, L, predict, store, xi, lambda, &live, &stats);
      }
    }
  }

  for (int w = 0; w < count; ++w) {
    Trajectory& tr = out[w];
    tr.sensitivities.clear();
    tr.summary = SimSummary();
    tr.summary.knots = solved + 1;
    tr.summary.newton_iterations = stats.newton_iterations;
    tr.summary.fallbacks = stats.fallbacks[w];
    tr.summary.unconverged = stats.unconverged[w];
    tr.summary.singular = inertial ? "" : singular[w];
    tr.summary.stopped = ((live >> w) & 1u) == 0;
    if (opt.record_velocities) {
      tr.knot_velocities.resize(solved + 1);
      for (int j = 0; j <= solved; ++j)
        for (int r = 0; r < 3; ++r) tr.knot_velocities[j][r] = ws.xi[(static_cast<size_t>(j) * 3 + r) * W + w];
    }
  }
}

Trajectory Simulator::Simulate(const ShapeDrive& drive, const Coefficients& c, const SimOptions& opt,
                               const PoseResets* resets) {
  SimWorkspace ws;
  Trajectory t;
  SimulateBatch(drive, &c, 1, opt, resets, ws, &t);
  return t;
}

Kinematics TrajectoryToKinematics(const ShapeDrive& drive, const Trajectory& traj, const Kinematics& source) {
  Kinematics k;
  k.fps = source.fps;
  k.metadata = source.metadata;
  k.metadata["source"] = "wormdrag simulate";
  k.frames.resize(source.frames.size());
  const double l = drive.body().link_length();
  for (size_t f = 0; f < source.frames.size(); ++f) {
    k.frames[f].t = source.frames[f].t;
    const int fi = static_cast<int>(f) - traj.first_frame;
    if (fi < 0 || fi >= static_cast<int>(traj.poses.size())) continue;
    k.frames[f].valid = true;
    k.frames[f].p = LabPoints(traj.poses[fi], drive.FrameShape(static_cast<int>(f)), l);
    k.frames[f].arc_length = drive.body().length;
  }
  return k;
}

}  // namespace wormdrag
