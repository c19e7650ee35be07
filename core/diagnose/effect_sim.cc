#include "core/diagnose/effect_sim.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include <Eigen/Dense>

#include "core/sim/cubic_spline.h"
#include "core/sim/pose_step.h"

namespace wormdrag::diagnose {
namespace {

constexpr double kTwoPi = 6.283185307179586;

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

// The velocity that minimises Φ (docs/conventions.md §2). Every law but stiction has a
// convex Φ, so Newton's root from any start is it. Stribeck friction makes Φ non-convex:
// the balance has several roots, and following the one nearest the previous knot's would
// make the path hinge on drive details far below tracking resolution (a ≥ 2.5: tens of µm
// from a < 0.01 µm drive change; docs/decisions/0025-stiction-least-root.md). So Newton
// also starts from the two convex laws that bracket it, Coulomb μ and static μ(1 + a)
// (unique roots that move smoothly with the shape), and the root of least Φ is kept; the
// warm start's root wins ties, so nothing changes where the roots agree.
bool SolveKnotImpl(const KnotGeometry& g, const double* mu, const double* eta, const EffectParams& p, double eps,
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

Vec2 HeadCentroid(const Shape& q, double l) {
  const Points pts = HeadFramePoints(q, l);
  Vec2 c = Vec2::Zero();
  for (const auto& x : pts) c += x;
  return c / kNumPoints;
}

Vec2 LabCentroid(const Pose& g, const Vec2& head_centroid) {
  const double c = std::cos(g.q0), s = std::sin(g.q0);
  return {g.x + c * head_centroid.x() - s * head_centroid.y(), g.y + s * head_centroid.x() + c * head_centroid.y()};
}

}  // namespace

Status EffectSimOptions::Validate() const {
  if (!(epsilon > 0) || !std::isfinite(epsilon)) return Status::InvalidArgument("eps must be a positive number");
  if (!(velocity_tolerance > 0)) return Status::InvalidArgument("velocity tolerance must be positive");
  if (max_iterations < 1) return Status::InvalidArgument("max iterations must be >= 1");
  return Status::Ok();
}

Result<EffectDrive> EffectDrive::FromKinematics(const Kinematics& k, const BodyModel& body, int substeps) {
  auto drive = ShapeDrive::Build(k, body, {substeps});
  if (!drive.ok()) return drive.status();
  EffectDrive d;
  d.drive_ = std::move(*drive);
  // Splines exactly as ShapeDrive::Build makes them (unwrapped along time).
  std::vector<double> ts;
  std::vector<std::vector<double>> qs(kNumJoints);
  Shape prev{};
  bool have_prev = false;
  bool in_gap = false;
  int gap_first = -1;
  for (int f = d.drive_.first_frame(); f <= d.drive_.last_frame(); ++f) {
    if (!k.frames[f].valid) {
      if (!in_gap) gap_first = f;
      in_gap = true;
      continue;
    }
    if (in_gap) d.gaps_.push_back({gap_first, f - 1});
    in_gap = false;
    Shape q = ShapeOf(k.frames[f].p);
    if (have_prev)
      for (int j = 0; j < kNumJoints; ++j) q[j] = prev[j] + WrapAngle(q[j] - prev[j]);
    prev = q;
    have_prev = true;
    ts.push_back(k.frames[f].t);
    for (int j = 0; j < kNumJoints; ++j) qs[j].push_back(q[j]);
  }
  auto splines = std::make_shared<std::vector<CubicSpline>>();
  for (int j = 0; j < kNumJoints; ++j) splines->emplace_back(ts, qs[j]);
  d.shape_ = [splines](double t, Shape* q, Shape* qd) {
    for (int j = 0; j < kNumJoints; ++j) (*splines)[j].Evaluate(t, &(*q)[j], &(*qd)[j]);
  };
  return d;
}

Result<EffectDrive> EffectDrive::FromFunction(const std::vector<double>& frame_times,
                                              const ShapeDrive::ShapeFunction& shape, const BodyModel& body,
                                              const Pose& initial, int substeps,
                                              std::vector<std::pair<int, int>> gaps) {
  auto drive = ShapeDrive::FromFunction(frame_times, shape, body, initial, {substeps});
  if (!drive.ok()) return drive.status();
  for (const auto& g : gaps)
    if (g.first < 1 || g.second < g.first || g.second + 1 >= static_cast<int>(frame_times.size()))
      return Status::InvalidArgument("a gap needs a frame on both sides");
  EffectDrive d;
  d.drive_ = std::move(*drive);
  d.shape_ = shape;
  d.gaps_ = std::move(gaps);
  return d;
}

void EffectDrive::ShapeAt(double t, Shape* q, Shape* qdot) const {
  shape_(std::clamp(t, t0(), t0() + span()), q, qdot);
}

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
  return SolveKnotImpl(g, mu, eta, p, eps, external, L, tol, max_iterations, xi, iterations);
}

EffectTrajectory SimulateEffects(const EffectDrive& ed, const Coefficients& c, const EffectParams& p,
                                 const EffectSimOptions& opt) {
  const ShapeDrive& drive = ed.drive();
  const auto& base_knots = drive.knots();
  const int n = static_cast<int>(base_knots.size());
  const BodyModel& body = drive.body();
  const double L = body.length, l0 = body.link_length();
  const double t0 = ed.t0(), T = std::max(ed.span(), 1e-12);
  EffectTrajectory tr;
  tr.first_frame = drive.first_frame();
  tr.knots = n;
  const int S = drive.substeps();
  const int nframes = drive.num_frames();

  // Geometry per knot: the drive's own unless lag or stretch change it.
  const bool own_geometry = p.lag != 0 || p.stretch != 0;
  std::vector<KnotGeometry> shifted;
  auto link_length_at = [&](double t) { return l0 * (1 + p.stretch * std::sin(kTwoPi * kStretchHz * (t - t0))); };
  if (own_geometry) {
    shifted.resize(n);
    for (int j = 0; j < n; ++j) {
      const double t = base_knots[j].t;
      Shape q, qd;
      ed.ShapeAt(t - p.lag, &q, &qd);
      BodyModel b = body;
      const double lt = link_length_at(t);
      b.length = lt * kNumLinks;
      shifted[j] = ComputeKnotGeometry(t, q, qd, b);
      if (p.stretch != 0) {
        // Stretching moves every point along its position vector: ṗ̂ = (L̇/L) p̂.
        const double rate = p.stretch * kTwoPi * kStretchHz * std::cos(kTwoPi * kStretchHz * (t - t0)) * l0 / lt;
        const Points pts = HeadFramePoints(q, lt);
        for (int k = 0; k < kNumLinks; ++k) {
          const Vec2 cc = 0.5 * (pts[k] + pts[k + 1]);
          for (int d = 0; d < 2; ++d) {
            const int i = 2 * k + d;
            shifted[j].b[i] += rate * (cc.x() * shifted[j].jx[i] + cc.y() * shifted[j].jy[i]);
          }
        }
      }
    }
  }
  const std::vector<KnotGeometry>& knots = own_geometry ? shifted : base_knots;
  tr.knot_velocities.assign(n, {0, 0, 0});
  tr.poses.resize(nframes);
  tr.link_length.resize(nframes, l0);
  for (int fi = 0; fi < nframes; ++fi) tr.link_length[fi] = p.stretch != 0 ? link_length_at(knots[fi * S].t) : l0;
  std::vector<double> mu(static_cast<size_t>(n) * kNumTerms), eta(mu.size());
  for (int j = 0; j < n; ++j) TermCoefficients(c, p, (knots[j].t - t0) / T, &mu[j * kNumTerms], &eta[j * kNumTerms]);

  std::vector<int> resets = opt.reset_frames;
  std::sort(resets.begin(), resets.end());
  auto is_reset = [&](int frame) { return std::binary_search(resets.begin(), resets.end(), frame); };
  const double medium[2] = {p.flow_x, p.flow_y};  // w of the flow effect (zero without it)
  const std::array<double, 3> no_ext{0, 0, 0};

  if (p.tether == 0) {
    // All knots first (ξ relative to the medium: a uniform flow adds w to the lab
    // velocity and changes nothing else), then the pose as core/sim integrates it.
    std::array<double, 3> xi{0, 0, 0};
    for (int j = 0; j < n; ++j) {
      if (j >= 2) {
        const double r = (knots[j].t - knots[j - 1].t) / (knots[j - 1].t - knots[j - 2].t);
        for (int k = 0; k < 3; ++k)
          xi[k] = tr.knot_velocities[j - 1][k] + r * (tr.knot_velocities[j - 1][k] - tr.knot_velocities[j - 2][k]);
      }
      if (!SolveKnotImpl(knots[j], &mu[j * kNumTerms], &eta[j * kNumTerms], p, opt.epsilon, no_ext, L,
                         opt.velocity_tolerance, opt.max_iterations, &xi, &tr.iterations))
        ++tr.unconverged;
      tr.knot_velocities[j] = xi;
    }
    Pose g = drive.initial_pose();
    tr.poses[0] = g;
    auto xi_at = [&](int k, int r) { return tr.knot_velocities[k][r]; };
    for (int j = 0; j + 1 < n; ++j) {
      double xm[3];
      MidpointXi(MidpointCubicAt(knots, j), xi_at, xm);
      PoseRk4Step(knots[j + 1].t - knots[j].t, tr.knot_velocities[j].data(), xm, tr.knot_velocities[j + 1].data(),
                  medium, &g);
      if ((j + 1) % S == 0) {
        const int fi = (j + 1) / S;
        const int frame = drive.first_frame() + fi;
        if (is_reset(frame)) g = drive.MeasuredPose(frame);
        tr.poses[fi] = g;
      }
    }
  } else {
    // Tether: the external force depends on the pose, so pose and velocity advance
    // together (Heun's method, the velocity re-solved at the predicted pose).
    Pose g = drive.initial_pose();
    auto centroid_h = [&](int j) {
      Shape q, qd;
      ed.ShapeAt(knots[j].t, &q, &qd);
      return HeadCentroid(q, p.stretch != 0 ? link_length_at(knots[j].t) : l0);
    };
    Vec2 anchor = LabCentroid(g, centroid_h(0));
    auto external = [&](int j, const Pose& pose) -> std::array<double, 3> {
      const Vec2 ch = centroid_h(j);
      const Vec2 F = -p.tether * (LabCentroid(pose, ch) - anchor);
      const double cs = std::cos(pose.q0), sn = std::sin(pose.q0);
      const Vec2 Fh(cs * F.x() + sn * F.y(), -sn * F.x() + cs * F.y());
      return {Fh.x(), Fh.y(), ch.x() * Fh.y() - ch.y() * Fh.x()};
    };
    std::array<double, 3> xi{0, 0, 0};
    auto solve = [&](int j, const Pose& pose, std::array<double, 3>* x) {
      if (!SolveKnotImpl(knots[j], &mu[j * kNumTerms], &eta[j * kNumTerms], p, opt.epsilon, external(j, pose), L,
                         opt.velocity_tolerance, opt.max_iterations, x, &tr.iterations))
        ++tr.unconverged;
    };
    solve(0, g, &xi);
    tr.knot_velocities[0] = xi;
    tr.poses[0] = g;
    for (int j = 0; j + 1 < n; ++j) {
      std::array<double, 3> xp;
      PoseHeunStep(
          knots[j + 1].t - knots[j].t, xi.data(), medium,
          [&](const Pose& pred) {
            xp = xi;
            solve(j + 1, pred, &xp);
            return xp.data();
          },
          &g);
      xi = xp;
      if ((j + 1) % S == 0) {
        const int fi = (j + 1) / S;
        const int frame = drive.first_frame() + fi;
        if (is_reset(frame)) {
          g = drive.MeasuredPose(frame);
          anchor = LabCentroid(g, centroid_h(j + 1));
        }
        tr.poses[fi] = g;
      }
      solve(j + 1, g, &xi);
      tr.knot_velocities[j + 1] = xi;
    }
  }

  // gap_offset: a measurement artefact applied to the recorded poses.
  if (p.gap_offset != 0 && !ed.gaps().empty()) {
    const int first = drive.first_frame();
    auto lab_centroid = [&](int frame) {
      const int fi = frame - first;
      return LabCentroid(tr.poses[fi], HeadCentroid(drive.FrameShape(frame), tr.link_length[fi]));
    };
    std::vector<Vec2> add(nframes, Vec2::Zero());
    size_t gi = 0;
    Vec2 acc = Vec2::Zero();
    int last_reset = -1;
    for (int fi = 0; fi < nframes; ++fi) {
      const int frame = first + fi;
      if (is_reset(frame)) {
        acc.setZero();
        last_reset = frame;
      }
      while (gi < ed.gaps().size() && ed.gaps()[gi].second + 1 < frame) ++gi;
      if (gi < ed.gaps().size() && ed.gaps()[gi].second + 1 == frame) {
        const int before = ed.gaps()[gi].first - 1;
        if (before >= first && last_reset <= before) acc += p.gap_offset * (lab_centroid(frame) - lab_centroid(before));
      }
      add[fi] = acc;
    }
    for (int fi = 0; fi < nframes; ++fi) {
      tr.poses[fi].x += add[fi].x();
      tr.poses[fi].y += add[fi].y();
    }
  }
  return tr;
}

Points EffectPoints(const EffectDrive& d, const EffectTrajectory& t, int frame) {
  const int fi = frame - t.first_frame;
  return LabPoints(t.poses[fi], d.drive().FrameShape(frame), t.link_length[fi]);
}

}  // namespace wormdrag::diagnose
