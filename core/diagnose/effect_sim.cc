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

namespace {

// What the integrators of SimulateEffects share: the drive, each knot's geometry and
// friction terms, and the frames where the pose resets to the measured one.
struct EffectRun {
  const EffectDrive& ed;
  const EffectParams& p;
  const EffectSimOptions& opt;
  const ShapeDrive& drive;
  double L, l0, t0;
  std::vector<KnotGeometry> own_knots;  // with lag or stretch: the geometry they change
  const std::vector<KnotGeometry>* knots = nullptr;
  std::vector<double> mu, eta;  // kNumTerms per knot
  std::vector<int> resets;      // sorted

  EffectRun(const EffectDrive& ed, const Coefficients& c, const EffectParams& p, const EffectSimOptions& opt)
      : ed(ed),
        p(p),
        opt(opt),
        drive(ed.drive()),
        L(drive.body().length),
        l0(drive.body().link_length()),
        t0(ed.t0()),
        resets(opt.reset_frames) {
    std::sort(resets.begin(), resets.end());
    if (p.lag != 0 || p.stretch != 0) own_knots = ShiftedGeometry();
    knots = own_knots.empty() ? &drive.knots() : &own_knots;
    const int n = static_cast<int>(knots->size());
    const double T = std::max(ed.span(), 1e-12);
    mu.resize(static_cast<size_t>(n) * kNumTerms);
    eta.resize(mu.size());
    for (int j = 0; j < n; ++j)
      effect_knot::TermCoefficients(c, p, ((*knots)[j].t - t0) / T, &mu[j * kNumTerms], &eta[j * kNumTerms]);
  }

  EffectRun(const EffectRun&) = delete;  // knots may point into own_knots
  EffectRun& operator=(const EffectRun&) = delete;

  double LinkLengthAt(double t) const { return l0 * (1 + p.stretch * std::sin(kTwoPi * kStretchHz * (t - t0))); }
  double LinkLengthOrBody(double t) const { return p.stretch != 0 ? LinkLengthAt(t) : l0; }
  bool IsReset(int frame) const { return std::binary_search(resets.begin(), resets.end(), frame); }

 private:
  // The drive's knots with the shape delayed by `lag` and the links stretched.
  std::vector<KnotGeometry> ShiftedGeometry() const {
    const auto& base = drive.knots();
    std::vector<KnotGeometry> shifted(base.size());
    for (size_t j = 0; j < base.size(); ++j) {
      const double t = base[j].t;
      Shape q, qd;
      ed.ShapeAt(t - p.lag, &q, &qd);
      BodyModel b = drive.body();
      const double lt = LinkLengthAt(t);
      b.length = lt * kNumLinks;
      shifted[j] = ComputeKnotGeometry(t, q, qd, b);
      if (p.stretch == 0) continue;
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
    return shifted;
  }
};

// Where knot j + 1 ends a frame: its pose, reset to the measured one where asked
// (then true).
bool RecordFrame(const EffectRun& run, int j, Pose* g, EffectTrajectory* tr) {
  const int S = run.drive.substeps();
  if ((j + 1) % S != 0) return false;
  const int fi = (j + 1) / S;
  const int frame = run.drive.first_frame() + fi;
  const bool reset = run.IsReset(frame);
  if (reset) *g = run.drive.MeasuredPose(frame);
  tr->poses[fi] = *g;
  return reset;
}

// Without tether or boundary the friction does not depend on the pose: all knots first
// (ξ relative to the medium: a uniform flow adds w to the lab velocity and changes
// nothing else), then the pose as core/sim integrates it.
void IntegrateQuasiStatic(const EffectRun& run, EffectTrajectory* tr) {
  const auto& knots = *run.knots;
  const int n = static_cast<int>(knots.size());
  const double medium[2] = {run.p.flow_x, run.p.flow_y};  // w of the flow effect (zero without it)
  const std::array<double, 3> no_ext{0, 0, 0};
  std::array<double, 3> xi{0, 0, 0};
  auto& v = tr->knot_velocities;
  for (int j = 0; j < n; ++j) {
    if (j >= 2) {
      const double r = (knots[j].t - knots[j - 1].t) / (knots[j - 1].t - knots[j - 2].t);
      for (int k = 0; k < 3; ++k) xi[k] = v[j - 1][k] + r * (v[j - 1][k] - v[j - 2][k]);
    }
    if (!effect_knot::SolveKnot(knots[j], &run.mu[j * kNumTerms], &run.eta[j * kNumTerms], run.p, run.opt.epsilon,
                                no_ext, run.L, run.opt.velocity_tolerance, run.opt.max_iterations, &xi,
                                &tr->iterations))
      ++tr->unconverged;
    v[j] = xi;
  }
  Pose g = run.drive.initial_pose();
  tr->poses[0] = g;
  auto xi_at = [&](int k, int r) { return v[k][r]; };
  for (int j = 0; j + 1 < n; ++j) {
    double xm[3];
    MidpointXi(MidpointCubicAt(knots, j), xi_at, xm);
    PoseRk4Step(knots[j + 1].t - knots[j].t, v[j].data(), xm, v[j + 1].data(), medium, &g);
    RecordFrame(run, j, &g, tr);
  }
}

// A knot solved at a given pose: the tether's force and the boundary's friction depend
// on where the body is.
class PoseDependentKnot {
 public:
  explicit PoseDependentKnot(const EffectRun& run)
      : run_(run), anchor_(LabCentroid(run.drive.initial_pose(), CentroidInHead(0))), boundary_x_(anchor_.x()) {}

  // The tether pulls toward the centroid of the last reset (the first frame's before one).
  void ResetAnchor(int j, const Pose& g) { anchor_ = LabCentroid(g, CentroidInHead(j)); }

  void Solve(int j, const Pose& pose, std::array<double, 3>* xi, EffectTrajectory* tr) {
    const auto [mj, ej] = FrictionAt(j, pose);
    if (!effect_knot::SolveKnot((*run_.knots)[j], mj, ej, run_.p, run_.opt.epsilon, External(j, pose), run_.L,
                                run_.opt.velocity_tolerance, run_.opt.max_iterations, xi, &tr->iterations))
      ++tr->unconverged;
  }

 private:
  Vec2 CentroidInHead(int j) const {
    Shape q, qd;
    const double t = (*run_.knots)[j].t;
    run_.ed.ShapeAt(t, &q, &qd);
    return HeadCentroid(q, run_.LinkLengthOrBody(t));
  }

  // Knot j's coefficients at `pose`: boundary's factor on every link (in mu_b_, eta_b_).
  std::pair<const double*, const double*> FrictionAt(int j, const Pose& pose) {
    const EffectParams& p = run_.p;
    if (p.boundary == 0) return {&run_.mu[j * kNumTerms], &run_.eta[j * kNumTerms]};
    // Every knot is solved at two or three poses, and its shape is the same at each.
    if (mid_knot_ != j) {
      Shape q, qd;
      const double t = (*run_.knots)[j].t;
      run_.ed.ShapeAt(t, &q, &qd);
      const Points pts = HeadFramePoints(q, run_.LinkLengthOrBody(t));
      for (int k = 0; k < kNumLinks; ++k) mid_[k] = 0.5 * (pts[k] + pts[k + 1]);
      mid_knot_ = j;
    }
    const double c = std::cos(pose.q0), s = std::sin(pose.q0);
    for (int k = 0; k < kNumLinks; ++k) {
      const Vec2& m = mid_[k];
      const double x = pose.x + c * m.x() - s * m.y();
      const double f = 1 + p.boundary / (1 + std::exp(-(x - boundary_x_) / kBoundaryWidth));
      for (int d = 0; d < 2; ++d) {
        mu_b_[2 * k + d] = run_.mu[j * kNumTerms + 2 * k + d] * f;
        eta_b_[2 * k + d] = run_.eta[j * kNumTerms + 2 * k + d] * f;
      }
    }
    return {mu_b_, eta_b_};
  }

  // The tether's wrench in the head frame.
  std::array<double, 3> External(int j, const Pose& pose) const {
    const Vec2 ch = CentroidInHead(j);
    const Vec2 F = -run_.p.tether * (LabCentroid(pose, ch) - anchor_);
    const double cs = std::cos(pose.q0), sn = std::sin(pose.q0);
    const Vec2 Fh(cs * F.x() + sn * F.y(), -sn * F.x() + cs * F.y());
    return {Fh.x(), Fh.y(), ch.x() * Fh.y() - ch.y() * Fh.x()};
  }

  const EffectRun& run_;
  Vec2 anchor_;
  const double boundary_x_;          // fixed on the plate, whatever the resets
  std::array<Vec2, kNumLinks> mid_;  // the links' head-frame midpoints of knot mid_knot_
  int mid_knot_ = -1;
  double mu_b_[kNumTerms], eta_b_[kNumTerms];
};

// Tether and boundary: pose and velocity advance together (Heun's method, the velocity
// re-solved at the predicted pose).
void IntegratePoseDependent(const EffectRun& run, EffectTrajectory* tr) {
  const auto& knots = *run.knots;
  const int n = static_cast<int>(knots.size());
  const double medium[2] = {run.p.flow_x, run.p.flow_y};
  PoseDependentKnot knot(run);
  Pose g = run.drive.initial_pose();
  std::array<double, 3> xi{0, 0, 0};
  knot.Solve(0, g, &xi, tr);
  tr->knot_velocities[0] = xi;
  tr->poses[0] = g;
  for (int j = 0; j + 1 < n; ++j) {
    std::array<double, 3> xp;
    auto at_predicted = [&](const Pose& pred) {
      xp = xi;
      knot.Solve(j + 1, pred, &xp, tr);
      return xp.data();
    };
    PoseHeunStep(knots[j + 1].t - knots[j].t, xi.data(), medium, at_predicted, &g);
    xi = xp;
    if (RecordFrame(run, j, &g, tr)) knot.ResetAnchor(j + 1, g);
    knot.Solve(j + 1, g, &xi, tr);
    tr->knot_velocities[j + 1] = xi;
  }
}

// gap_offset: a measurement artefact applied to the recorded poses.
void ApplyGapOffset(const EffectRun& run, EffectTrajectory* tr) {
  const auto& gaps = run.ed.gaps();
  const int first = run.drive.first_frame();
  const int nframes = run.drive.num_frames();
  auto lab_centroid = [&](int frame) {
    const int fi = frame - first;
    return LabCentroid(tr->poses[fi], HeadCentroid(run.drive.FrameShape(frame), tr->link_length[fi]));
  };
  std::vector<Vec2> add(nframes, Vec2::Zero());
  size_t gi = 0;
  Vec2 acc = Vec2::Zero();
  int last_reset = -1;
  for (int fi = 0; fi < nframes; ++fi) {
    const int frame = first + fi;
    if (run.IsReset(frame)) {
      acc.setZero();
      last_reset = frame;
    }
    while (gi < gaps.size() && gaps[gi].second + 1 < frame) ++gi;
    if (gi < gaps.size() && gaps[gi].second + 1 == frame) {
      const int before = gaps[gi].first - 1;
      if (before >= first && last_reset <= before)
        acc += run.p.gap_offset * (lab_centroid(frame) - lab_centroid(before));
    }
    add[fi] = acc;
  }
  for (int fi = 0; fi < nframes; ++fi) {
    tr->poses[fi].x += add[fi].x();
    tr->poses[fi].y += add[fi].y();
  }
}

}  // namespace

EffectTrajectory SimulateEffects(const EffectDrive& ed, const Coefficients& c, const EffectParams& p,
                                 const EffectSimOptions& opt) {
  const EffectRun run(ed, c, p, opt);
  const int n = static_cast<int>(run.knots->size());
  const int nframes = run.drive.num_frames();
  EffectTrajectory tr;
  tr.first_frame = run.drive.first_frame();
  tr.knots = n;
  tr.knot_velocities.assign(n, {0, 0, 0});
  tr.poses.resize(nframes);
  tr.link_length.resize(nframes);
  for (int fi = 0; fi < nframes; ++fi)
    tr.link_length[fi] = run.LinkLengthOrBody((*run.knots)[fi * run.drive.substeps()].t);
  if (p.tether == 0 && p.boundary == 0)
    IntegrateQuasiStatic(run, &tr);
  else
    IntegratePoseDependent(run, &tr);
  if (p.gap_offset != 0 && !ed.gaps().empty()) ApplyGapOffset(run, &tr);
  return tr;
}

Points EffectPoints(const EffectDrive& d, const EffectTrajectory& t, int frame) {
  const int fi = frame - t.first_frame;
  return LabPoints(t.poses[fi], d.drive().FrameShape(frame), t.link_length[fi]);
}

}  // namespace wormdrag::diagnose
