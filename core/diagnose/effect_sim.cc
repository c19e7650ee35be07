#include "core/diagnose/effect_sim.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "core/diagnose/internal/effect_knot.h"
#include "core/sim/cubic_spline.h"
#include "core/sim/pose_step.h"

namespace wormdrag::diagnose {
namespace {

constexpr double kTwoPi = 6.283185307179586;

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
  for (int j = 0; j < n; ++j)
    effect_knot::TermCoefficients(c, p, (knots[j].t - t0) / T, &mu[j * kNumTerms], &eta[j * kNumTerms]);

  std::vector<int> resets = opt.reset_frames;
  std::sort(resets.begin(), resets.end());
  auto is_reset = [&](int frame) { return std::binary_search(resets.begin(), resets.end(), frame); };
  const double medium[2] = {p.flow_x, p.flow_y};  // w of the flow effect (zero without it)
  const std::array<double, 3> no_ext{0, 0, 0};

  if (p.tether == 0 && p.boundary == 0) {
    // All knots first (ξ relative to the medium: a uniform flow adds w to the lab
    // velocity and changes nothing else), then the pose as core/sim integrates it.
    std::array<double, 3> xi{0, 0, 0};
    for (int j = 0; j < n; ++j) {
      if (j >= 2) {
        const double r = (knots[j].t - knots[j - 1].t) / (knots[j - 1].t - knots[j - 2].t);
        for (int k = 0; k < 3; ++k)
          xi[k] = tr.knot_velocities[j - 1][k] + r * (tr.knot_velocities[j - 1][k] - tr.knot_velocities[j - 2][k]);
      }
      if (!effect_knot::SolveKnot(knots[j], &mu[j * kNumTerms], &eta[j * kNumTerms], p, opt.epsilon, no_ext, L,
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
    // Tether and boundary: the external force or the friction depends on the pose, so
    // pose and velocity advance together (Heun's method, the velocity re-solved at the
    // predicted pose).
    Pose g = drive.initial_pose();
    auto centroid_h = [&](int j) {
      Shape q, qd;
      ed.ShapeAt(knots[j].t, &q, &qd);
      return HeadCentroid(q, p.stretch != 0 ? link_length_at(knots[j].t) : l0);
    };
    Vec2 anchor = LabCentroid(g, centroid_h(0));
    const double boundary_x = anchor.x();  // fixed on the plate, whatever the resets
    double mu_b[kNumTerms], eta_b[kNumTerms];
    // The links' head-frame midpoints of knot `mid_knot`: every knot is solved at two or
    // three poses, and its shape is the same at each.
    std::array<Vec2, kNumLinks> mid;
    int mid_knot = -1;
    // Knot j's coefficients at `pose`: boundary's factor on every link (in mu_b, eta_b).
    auto coefficients = [&](int j, const Pose& pose) -> std::pair<const double*, const double*> {
      if (p.boundary == 0) return {&mu[j * kNumTerms], &eta[j * kNumTerms]};
      if (mid_knot != j) {
        Shape q, qd;
        ed.ShapeAt(knots[j].t, &q, &qd);
        const Points pts = HeadFramePoints(q, p.stretch != 0 ? link_length_at(knots[j].t) : l0);
        for (int k = 0; k < kNumLinks; ++k) mid[k] = 0.5 * (pts[k] + pts[k + 1]);
        mid_knot = j;
      }
      const double c = std::cos(pose.q0), s = std::sin(pose.q0);
      for (int k = 0; k < kNumLinks; ++k) {
        const Vec2& m = mid[k];
        const double x = pose.x + c * m.x() - s * m.y();
        const double f = 1 + p.boundary / (1 + std::exp(-(x - boundary_x) / kBoundaryWidth));
        for (int d = 0; d < 2; ++d) {
          mu_b[2 * k + d] = mu[j * kNumTerms + 2 * k + d] * f;
          eta_b[2 * k + d] = eta[j * kNumTerms + 2 * k + d] * f;
        }
      }
      return {mu_b, eta_b};
    };
    auto external = [&](int j, const Pose& pose) -> std::array<double, 3> {
      const Vec2 ch = centroid_h(j);
      const Vec2 F = -p.tether * (LabCentroid(pose, ch) - anchor);
      const double cs = std::cos(pose.q0), sn = std::sin(pose.q0);
      const Vec2 Fh(cs * F.x() + sn * F.y(), -sn * F.x() + cs * F.y());
      return {Fh.x(), Fh.y(), ch.x() * Fh.y() - ch.y() * Fh.x()};
    };
    std::array<double, 3> xi{0, 0, 0};
    auto solve = [&](int j, const Pose& pose, std::array<double, 3>* x) {
      const auto [mj, ej] = coefficients(j, pose);
      if (!effect_knot::SolveKnot(knots[j], mj, ej, p, opt.epsilon, external(j, pose), L, opt.velocity_tolerance,
                                  opt.max_iterations, x, &tr.iterations))
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
