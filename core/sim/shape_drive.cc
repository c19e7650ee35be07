#include "core/sim/shape_drive.h"

#include <cmath>

#include "core/sim/cubic_spline.h"

namespace wormdrag {

KnotGeometry ComputeKnotGeometry(double t, const Shape& q, const Shape& qdot, const BodyModel& body) {
  KnotGeometry g;
  g.t = t;
  const double l = body.link_length(), m = body.link_mass, inertia = body.link_inertia();
  double phi = 0, phidot = 0;
  Vec2 joint = Vec2::Zero(), joint_dot = Vec2::Zero();  // p̂_{k} and its shape velocity
  double M00 = 0, M01 = 0, M02 = 0, M11 = 0, M12 = 0, M22 = 0, s0 = 0, s1 = 0, s2 = 0;
  for (int k = 0; k < kNumLinks; ++k) {
    if (k > 0) {
      phi += q[k - 1];
      phidot += qdot[k - 1];
    }
    const Vec2 tan(std::cos(phi), std::sin(phi)), nor(-std::sin(phi), std::cos(phi));
    const Vec2 c = joint + 0.5 * l * tan;                  // link centre ĉ_k
    const Vec2 cdot = joint_dot + 0.5 * l * phidot * nor;  // its shape velocity
    const double cross_ct = c.x() * tan.y() - c.y() * tan.x();
    const double cross_cn = c.x() * nor.y() - c.y() * nor.x();
    g.jx[2 * k] = tan.x();
    g.jy[2 * k] = tan.y();
    g.jw[2 * k] = cross_ct;
    g.b[2 * k] = tan.dot(cdot);
    g.jx[2 * k + 1] = nor.x();
    g.jy[2 * k + 1] = nor.y();
    g.jw[2 * k + 1] = cross_cn;
    g.b[2 * k + 1] = nor.dot(cdot);
    // Momentum of link k: m v̂_c = m (V + ω Jĉ + ĉ̇); spin I (ω + φ̇).
    M00 += m;
    M11 += m;
    M02 += -m * c.y();
    M12 += m * c.x();
    M22 += m * c.squaredNorm() + inertia;
    s0 += m * cdot.x();
    s1 += m * cdot.y();
    s2 += m * (c.x() * cdot.y() - c.y() * cdot.x()) + inertia * phidot;
    joint += l * tan;
    joint_dot += l * phidot * nor;
  }
  g.mass = {M00, M01, M02, M11, M12, M22};
  g.shape_momentum = {s0, s1, s2};
  return g;
}

namespace {

Status CheckKnots(int64_t frames, int substeps) {
  const int64_t knots = KnotCountFor(frames, substeps);
  if (knots <= kMaxKnots) return Status::Ok();
  return Status::InvalidArgument(std::to_string(frames) + " frames at " + std::to_string(substeps) +
                                 " knots per frame need " + std::to_string(knots) + " solver knots; at most " +
                                 std::to_string(kMaxKnots) + " are allowed (is the frame rate right?)");
}

}  // namespace

Result<ShapeDrive> ShapeDrive::Build(const Kinematics& k, const BodyModel& body, const ShapeDriveOptions& opt) {
  if (opt.substeps < 1) return Status::InvalidArgument("substeps must be >= 1");
  if (!(body.length > 0)) return Status::InvalidArgument("body length must be positive");
  ShapeDrive d;
  d.body_ = body;
  d.substeps_ = opt.substeps;
  int first = -1, last = -1;
  for (int f = 0; f < static_cast<int>(k.frames.size()); ++f)
    if (k.frames[f].valid) {
      if (first < 0) first = f;
      last = f;
    }
  if (first < 0 || first == last) return Status::InvalidArgument("a recording needs at least 2 valid frames");
  d.first_frame_ = first;
  d.last_frame_ = last;
  d.num_frames_ = last - first + 1;
  WORMDRAG_RETURN_IF_ERROR(CheckKnots(d.num_frames_, d.substeps_));

  // Joint-angle splines through the valid frames, angles unwrapped along time.
  std::vector<double> ts;
  std::vector<std::vector<double>> qs(kNumJoints);
  Shape prev{};
  bool have_prev = false;
  for (int f = first; f <= last; ++f) {
    if (!k.frames[f].valid) continue;
    Shape q = ShapeOf(k.frames[f].p);
    if (have_prev)
      for (int j = 0; j < kNumJoints; ++j) q[j] = prev[j] + WrapAngle(q[j] - prev[j]);
    prev = q;
    have_prev = true;
    ts.push_back(k.frames[f].t);
    for (int j = 0; j < kNumJoints; ++j) qs[j].push_back(q[j]);
  }
  std::vector<CubicSpline> splines;
  splines.reserve(kNumJoints);
  for (int j = 0; j < kNumJoints; ++j) splines.emplace_back(ts, qs[j]);

  const double l = body.link_length();
  d.frame_shapes_.resize(d.num_frames_);
  d.measured_poses_.resize(d.num_frames_);
  d.knots_.reserve((d.num_frames_ - 1) * d.substeps_ + 1);
  for (int f = first; f <= last; ++f) {
    const int nsub = f == last ? 1 : d.substeps_;
    const double t0 = k.frames[f].t, t1 = f == last ? t0 : k.frames[f + 1].t;
    for (int s = 0; s < nsub; ++s) {
      const double t = t0 + (t1 - t0) * s / nsub;
      Shape q, qd;
      for (int j = 0; j < kNumJoints; ++j) splines[j].Evaluate(t, &q[j], &qd[j]);
      if (s == 0) d.frame_shapes_[f - first] = q;
      d.knots_.push_back(ComputeKnotGeometry(t, q, qd, body));
    }
    if (k.frames[f].valid) d.measured_poses_[f - first] = BestFitPose(k.frames[f].p, d.frame_shapes_[f - first], l);
  }
  d.initial_pose_ = d.measured_poses_[0];
  return d;
}

Result<ShapeDrive> ShapeDrive::FromFunction(const std::vector<double>& frame_times, const ShapeFunction& shape,
                                            const BodyModel& body, const Pose& initial, const ShapeDriveOptions& opt) {
  if (opt.substeps < 1) return Status::InvalidArgument("substeps must be >= 1");
  if (!(body.length > 0)) return Status::InvalidArgument("body length must be positive");
  if (frame_times.size() < 2) return Status::InvalidArgument("a recording needs at least 2 frames");
  WORMDRAG_RETURN_IF_ERROR(CheckKnots(static_cast<int64_t>(frame_times.size()), opt.substeps));
  ShapeDrive d;
  d.body_ = body;
  d.substeps_ = opt.substeps;
  d.first_frame_ = 0;
  d.num_frames_ = static_cast<int>(frame_times.size());
  d.last_frame_ = d.num_frames_ - 1;
  d.frame_shapes_.resize(d.num_frames_);
  d.measured_poses_.assign(d.num_frames_, initial);
  for (int f = 0; f < d.num_frames_; ++f) {
    const int nsub = f == d.last_frame_ ? 1 : d.substeps_;
    const double t0 = frame_times[f], t1 = f == d.last_frame_ ? t0 : frame_times[f + 1];
    if (f > 0 && !(t0 > frame_times[f - 1])) return Status::InvalidArgument("frame times must increase");
    for (int s = 0; s < nsub; ++s) {
      const double t = t0 + (t1 - t0) * s / nsub;
      Shape q, qd;
      shape(t, &q, &qd);
      if (s == 0) d.frame_shapes_[f] = q;
      d.knots_.push_back(ComputeKnotGeometry(t, q, qd, body));
    }
  }
  d.initial_pose_ = initial;
  return d;
}

}  // namespace wormdrag
