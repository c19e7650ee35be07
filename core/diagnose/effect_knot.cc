#include "core/diagnose/internal/effect_knot.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>

#include "core/diagnose/effect_sim.h"

namespace wormdrag::diagnose {
namespace {

// R = Σ J f − ext and H = Σ f' J Jᵀ (upper triangle 00 01 02 11 12 22).
void Balance(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
             const std::array<double, 3>& ext, const std::array<double, 3>& xi, double R[3], double H[6]) {
  R[0] = -ext[0];
  R[1] = -ext[1];
  R[2] = -ext[2];
  if (H) std::fill(H, H + 6, 0.0);
  const bool plain = !p.ChangesLaw();
  for (int i = 0; i < kNumTerms; ++i) {
    const double v = g.jx[i] * xi[0] + g.jy[i] * xi[1] + g.jw[i] * xi[2] + g.b[i];
    double f, df;
    if (plain) {
      const double s = std::sqrt(v * v + eps * eps);
      f = mu[i] * v / s + eta[i] * v;
      df = mu[i] * eps * eps / (s * s * s) + eta[i];
    } else {
      EffectForce(v, mu[i], eta[i], i & 1, p, eps, &f, &df);
    }
    R[0] += g.jx[i] * f;
    R[1] += g.jy[i] * f;
    R[2] += g.jw[i] * f;
    if (H) {
      const double jx = g.jx[i], jy = g.jy[i], jw = g.jw[i];
      H[0] += df * jx * jx;
      H[1] += df * jx * jy;
      H[2] += df * jx * jw;
      H[3] += df * jy * jy;
      H[4] += df * jy * jw;
      H[5] += df * jw * jw;
    }
  }
}

// The dissipation potential of one term, Φ_i(v) = ∫_0^v f: exact for the base law,
// the lateral asymmetry and (up to O(ε)) stiction and the power law. Used only to
// accept Newton steps; convergence is judged on the step.
double TermPotential(double v, double mu, double eta, bool normal, const EffectParams& p, double eps) {
  const double s = std::sqrt(v * v + eps * eps) - eps;
  if (p.power_law) {
    const double C = mu + eta * kPowerLawVRef;
    return C * std::pow(std::abs(v) / kPowerLawVRef, p.power_n) * std::abs(v) / (p.power_n + 1);
  }
  double phi = mu * s + 0.5 * eta * v * v;
  const double la = normal ? p.lateral_asymmetry : 0.0;
  if (la != 0) phi += mu * 0.5 * la * (s + v - eps * std::atan(v / eps));
  if (p.stiction != 0) {
    // ∫ e^{−(u/v_s)²} sgnε(u) du = v_s (√π/2) erf(|v|/v_s) + (sqrt(v² + ε²) − ε − |v|) + O(ε³/v_s²).
    const double e = mu * p.stiction *
                     (kStictionVs * 0.886226925452758 * std::erf(std::abs(v) / kStictionVs) + s - std::abs(v));
    phi += e;
    if (la != 0 && v > 0) phi += la * e;
  }
  return phi;
}

double Potential(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
                 const std::array<double, 3>& ext, const std::array<double, 3>& xi) {
  double phi = -(ext[0] * xi[0] + ext[1] * xi[1] + ext[2] * xi[2]);
  for (int i = 0; i < kNumTerms; ++i) {
    const double v = g.jx[i] * xi[0] + g.jy[i] * xi[1] + g.jw[i] * xi[2] + g.b[i];
    phi += TermPotential(v, mu[i], eta[i], i & 1, p, eps);
  }
  return phi;
}

// Damped Newton on the balance R(ξ) = ∇Φ(ξ) = 0. The direction is Newton's where the
// Hessian is positive definite and the eigenvalue-modified Newton direction where it is
// not (non-monotone stiction), so it always descends Φ; a step is accepted when it
// decreases Φ (Armijo) or the merit ‖R‖² (near the root, where Φ's O(ε) approximations
// for stiction could mislead).
bool NewtonStage(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
                 const std::array<double, 3>& ext, double L, double tol, int max_it, std::array<double, 3>* xi_io,
                 long* iterations) {
  std::array<double, 3> xi = *xi_io;
  const double wL = 1.0 / (L * L);  // moment weighted to force units
  double R[3], H[6];
  auto merit = [&](const double* r) { return r[0] * r[0] + r[1] * r[1] + wL * r[2] * r[2]; };
  Balance(g, mu, eta, p, eps, ext, xi, R, H);
  double m = merit(R);
  double phi = Potential(g, mu, eta, p, eps, ext, xi);
  const bool approximate = p.power_law;
  for (int it = 0; it < max_it; ++it) {
    ++*iterations;
    Eigen::Matrix3d Hm;
    Hm << H[0], H[1], H[2], H[1], H[3], H[4], H[2], H[4], H[5];
    const Eigen::Vector3d Rv(R[0], R[1], R[2]);
    Eigen::Vector3d d;
    Eigen::LLT<Eigen::Matrix3d> llt(Hm);
    bool pd = llt.info() == Eigen::Success;
    if (pd) {
      d = -llt.solve(Rv);
      pd = d.allFinite();
    }
    if (!pd) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Hm);
      Eigen::Vector3d lam = es.eigenvalues().cwiseAbs();
      const double floor = 1e-10 * std::max(1e-12, lam.maxCoeff());
      for (int r = 0; r < 3; ++r) lam[r] = std::max(lam[r], floor);
      d = -(es.eigenvectors() * (es.eigenvectors().transpose() * Rv).cwiseQuotient(lam));
    }
    const double slope = Rv.dot(d);  // < 0
    double a = 1.0, Rt[3], Ht[6], phit = phi, mt = m;
    std::array<double, 3> trial;
    bool accepted = false;
    for (int ls = 0; ls < 60; ++ls) {
      for (int r = 0; r < 3; ++r) trial[r] = xi[r] + a * d[r];
      phit = Potential(g, mu, eta, p, eps, ext, trial);
      if (phit <= phi + 1e-4 * a * slope) {
        Balance(g, mu, eta, p, eps, ext, trial, Rt, Ht);
        mt = merit(Rt);
        accepted = true;
        break;
      }
      Balance(g, mu, eta, p, eps, ext, trial, Rt, Ht);
      mt = merit(Rt);
      // Φ is exact for the base law and the lateral asymmetry; with stiction or the power
      // law its O(ε) approximation may disagree with R inside the kinks, so a decrease of
      // the merit also counts there.
      const bool flat = approximate || std::abs(phit - phi) <= 1e-13 * (std::abs(phi) + 1e-300);
      if (phit <= phi + 1e-4 * a * slope || (flat && mt <= (1 - 1e-4 * a) * m)) {
        accepted = true;
        break;
      }
      a *= 0.5;
    }
    const double step = a * (std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]) * L);
    if (!accepted) {  // no decrease even for tiny steps: at the root to rounding, or stalled
      *xi_io = xi;
      return std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]) * L < tol || m < 1e-28;
    }
    xi = trial;
    phi = phit;
    m = mt;
    std::copy(Rt, Rt + 3, R);
    std::copy(Ht, Ht + 6, H);
    if (step < tol && (a == 1.0 || std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]) * L < tol)) {
      *xi_io = xi;
      return true;
    }
  }
  *xi_io = xi;
  return false;
}

// Newton from the start *xi_io; if that stalls (a cold start far from the solution with
// a small ε makes the Coulomb kinks nearly non-smooth), ε-continuation: the problem is
// solved with ε = 1e-2, 1e-3 … mm/s, each stage starting from the last.
bool SolveFromStart(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
                    const std::array<double, 3>& ext, double L, double tol, int max_it, std::array<double, 3>* xi_io,
                    long* iterations) {
  std::array<double, 3> xi = *xi_io;
  if (NewtonStage(g, mu, eta, p, eps, ext, L, tol, std::min(max_it, 30), &xi, iterations)) {
    *xi_io = xi;
    return true;
  }
  xi = *xi_io;
  for (double e = 1e-2 * L; e > eps; e *= 0.1)
    NewtonStage(g, mu, eta, p, e, ext, L, std::max(tol, 1e-3 * e), max_it, &xi, iterations);
  const bool ok = NewtonStage(g, mu, eta, p, eps, ext, L, tol, max_it, &xi, iterations);
  *xi_io = xi;
  return ok;
}

}  // namespace

namespace effect_knot {

// Per-term coefficients at a knot: base × body_gradient (× time_drift on normal terms).
void TermCoefficients(const Coefficients& c, const EffectParams& p, double tau, double mu[kNumTerms],
                      double eta[kNumTerms]) {
  const double drift = 1.0 + p.time_drift * (tau - 0.5);
  for (int i = 0; i < kNumTerms; ++i) {
    const int link = i / 2 + 1;
    const double s = p.body_gradient != 0 ? BodyGradientFactor(p.body_gradient, link) : 1.0;
    if (i & 1) {
      mu[i] = c.mu_n * s * drift;
      eta[i] = c.eta_n * s * drift;
    } else {
      mu[i] = c.mu_t * s;
      eta[i] = c.eta_t * s;
    }
  }
}

// The velocity that minimises Φ (docs/conventions.md §2). Every law but stiction has a
// convex Φ, so Newton's root from any start is it. Stribeck friction makes Φ non-convex:
// the balance has several roots, and following the one nearest the previous knot's would
// make the path hinge on drive details far below tracking resolution (a ≥ 2.5: tens of µm
// from a < 0.01 µm drive change; docs/decisions/0025-stiction-least-root.md). So Newton
// also starts from the two convex laws that bracket it, Coulomb μ and static μ(1 + a)
// (unique roots that move smoothly with the shape), and the root of least Φ is kept; the
// warm start's root wins ties, so nothing changes where the roots agree.
bool SolveKnot(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
               const std::array<double, 3>& ext, double L, double tol, int max_it, std::array<double, 3>* xi_io,
               long* iterations) {
  if (p.stiction == 0) return SolveFromStart(g, mu, eta, p, eps, ext, L, tol, max_it, xi_io, iterations);
  std::array<double, 3> best = *xi_io;
  bool best_ok = SolveFromStart(g, mu, eta, p, eps, ext, L, tol, max_it, &best, iterations);
  double best_phi = Potential(g, mu, eta, p, eps, ext, best);
  EffectParams convex = p;
  convex.stiction = 0;
  double mu_static[kNumTerms];
  for (int i = 0; i < kNumTerms; ++i) mu_static[i] = mu[i] * (1 + p.stiction);
  for (const double* mu_start : {mu, static_cast<const double*>(mu_static)}) {
    std::array<double, 3> xi = *xi_io;
    SolveFromStart(g, mu_start, eta, convex, eps, ext, L, tol, max_it, &xi, iterations);
    const bool ok = SolveFromStart(g, mu, eta, p, eps, ext, L, tol, max_it, &xi, iterations);
    const double phi = Potential(g, mu, eta, p, eps, ext, xi);
    if (ok && (!best_ok || phi < best_phi - 1e-12 * std::abs(best_phi))) {
      best = xi;
      best_phi = phi;
      best_ok = true;
    }
  }
  *xi_io = best;
  return best_ok;
}

}  // namespace effect_knot

using effect_knot::SolveKnot;
using effect_knot::TermCoefficients;

std::array<double, 3> EffectWrench(const KnotGeometry& g, const Coefficients& c, const EffectParams& p, double tau,
                                   double eps, const std::array<double, 3>& xi) {
  double mu[kNumTerms], eta[kNumTerms], R[3];
  TermCoefficients(c, p, tau, mu, eta);
  Balance(g, mu, eta, p, eps, {0, 0, 0}, xi, R, nullptr);
  return {-R[0], -R[1], -R[2]};
}

bool SolveEffectKnot(const KnotGeometry& g, const Coefficients& c, const EffectParams& p, double tau, double eps,
                     const std::array<double, 3>& external, double L, double tol, int max_iterations,
                     std::array<double, 3>* xi, long* iterations) {
  double mu[kNumTerms], eta[kNumTerms];
  TermCoefficients(c, p, tau, mu, eta);
  return SolveKnot(g, mu, eta, p, eps, external, L, tol, max_iterations, xi, iterations);
}

}  // namespace wormdrag::diagnose
