#include "core/analysis/forces.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace wormdrag {

void HeadFrameLinkForces(const KnotGeometry& g, const Shape& q, const Coefficients& c, double eps,
                         const std::array<double, 3>& xi, std::array<Vec2, kNumLinks>* force,
                         std::array<Vec2, kNumLinks>* velocity, std::array<double, kNumLinks>* f_t,
                         std::array<double, kNumLinks>* f_n) {
  const auto phi = RelativeLinkAngles(q);
  for (int k = 0; k < kNumLinks; ++k) {
    const Vec2 tk(std::cos(phi[k]), std::sin(phi[k])), nk(-std::sin(phi[k]), std::cos(phi[k]));
    double v[2], f[2];
    for (int d = 0; d < 2; ++d) {
      const int i = 2 * k + d;
      v[d] = g.jx[i] * xi[0] + g.jy[i] * xi[1] + g.jw[i] * xi[2] + g.b[i];
      const double mu = d == 0 ? c.mu_t : c.mu_n, eta = d == 0 ? c.eta_t : c.eta_n;
      f[d] = -mu * SmoothSign(v[d], eps) - eta * v[d];
    }
    (*force)[k] = f[0] * tk + f[1] * nk;
    (*velocity)[k] = v[0] * tk + v[1] * nk;
    (*f_t)[k] = f[0];
    (*f_n)[k] = f[1];
  }
}

namespace {

// The forces of one simulated frame, in the lab frame, and what the series keeps of them.
struct FrameForces {
  std::array<Vec2, kNumLinks> force;
  std::array<double, kNumLinks> f_t, f_n;
  Vec2 net = Vec2::Zero(), centroid_velocity = Vec2::Zero();
  double moment = 0, magnitude = 0, power = 0, thrust = 0;
};

FrameForces ForcesAt(const KnotGeometry& g, const Shape& q, const Coefficients& c, double eps,
                     const std::array<double, 3>& xi, const Pose& pose, double link_length) {
  FrameForces out;
  std::array<Vec2, kNumLinks> fh, vh;
  HeadFrameLinkForces(g, q, c, eps, xi, &fh, &vh, &out.f_t, &out.f_n);
  const double cs = std::cos(pose.q0), sn = std::sin(pose.q0);
  auto rot = [&](const Vec2& v) { return Vec2(cs * v.x() - sn * v.y(), sn * v.x() + cs * v.y()); };
  const Points hp = HeadFramePoints(q, link_length);
  for (int k = 0; k < kNumLinks; ++k) {
    out.force[k] = rot(fh[k]);
    out.net += out.force[k];
    const Vec2 ck = 0.5 * (hp[k] + hp[k + 1]);  // head frame, relative to p_0
    out.moment += ck.x() * fh[k].y() - ck.y() * fh[k].x();
    out.magnitude += out.force[k].norm();
    out.power -= fh[k].dot(vh[k]);
    out.centroid_velocity += rot(vh[k]) / kNumLinks;
  }
  if (out.centroid_velocity.norm() > 0) {
    const Vec2 u = out.centroid_velocity.normalized();
    for (int k = 0; k < kNumLinks; ++k) out.thrust += std::max(0.0, out.force[k].dot(u));
  }
  return out;
}

void Append(const FrameForces& f, int frame, double t, bool summarize, LinkForceSeries* s) {
  s->summarized.push_back(summarize);
  s->frame.push_back(frame);
  s->t.push_back(t);
  s->force.push_back(f.force);
  s->f_t.push_back(f.f_t);
  s->f_n.push_back(f.f_n);
  s->net.push_back(f.net);
  s->net_moment.push_back(f.moment);
  s->magnitude_sum.push_back(f.magnitude);
  s->thrust.push_back(f.thrust);
  s->power.push_back(f.power);
  s->centroid_velocity.push_back(f.centroid_velocity);
}

}  // namespace

Result<LinkForceSeries> ComputeLinkForces(const ShapeDrive& drive, const Coefficients& c, const SimOptions& opt,
                                          const PoseResets* resets) {
  SimOptions o = opt;
  o.record_velocities = true;
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  Trajectory tr = Simulator::Simulate(drive, c, o, resets);
  if (!tr.summary.singular.empty())
    return Status::FailedPrecondition("coefficients " + c.ToString() + " cannot be simulated: " + tr.summary.singular);
  if (tr.knot_velocities.size() != drive.knots().size())
    return Status::Internal("the simulator did not record the knot velocities");
  LinkForceSeries s;
  s.coefficients = c;
  s.body_length = drive.body().length;
  s.sim = tr.summary;
  double sum_link2 = 0, sum_net2 = 0;
  long n_link = 0, n_summary = 0;
  // The simulated body starts (and restarts after gaps) at rest, so the first knot of a
  // stretch carries the start-up acceleration: kept in the series, left out of the summaries.
  auto starts_stretch = [&](int f) {
    if (f == drive.first_frame()) return true;
    if (resets)
      for (int r : resets->frames)
        if (r == f) return true;
    return false;
  };
  for (size_t i = 0; i < tr.poses.size(); ++i) {
    const int f = tr.first_frame + static_cast<int>(i);
    if (f < drive.first_frame() || f > drive.last_frame()) continue;
    const int knot = drive.KnotOfFrame(f);
    const KnotGeometry& g = drive.knots()[knot];
    const FrameForces ff = ForcesAt(g, drive.FrameShape(f), c, opt.epsilon, tr.knot_velocities[knot], tr.poses[i],
                                    drive.body().link_length());
    const bool summarize = !starts_stretch(f);
    if (summarize) {
      for (int k = 0; k < kNumLinks; ++k) sum_link2 += ff.force[k].squaredNorm();
      n_link += kNumLinks;
      ++n_summary;
      sum_net2 += ff.net.squaredNorm();
    }
    Append(ff, f, g.t, summarize, &s);
  }
  if (n_summary == 0) return Status::FailedPrecondition("no simulated frame to evaluate forces at");
  const double n = static_cast<double>(n_summary);
  s.rms_link = std::sqrt(sum_link2 / n_link);
  s.rms_net = std::sqrt(sum_net2 / n);
  for (size_t i = 0; i < s.t.size(); ++i) {
    if (!s.summarized[i]) continue;
    s.mean_magnitude_sum += s.magnitude_sum[i] / n;
    s.mean_thrust += s.thrust[i] / n;
    s.mean_power += s.power[i] / n;
  }
  return s;
}

std::string LinkForcesCsv(const LinkForceSeries& s) {
  std::string out = "t";
  for (int k = 1; k <= kNumLinks; ++k)
    out += ",fx" + std::to_string(k) + ",fy" + std::to_string(k) + ",ft" + std::to_string(k) + ",fn" +
           std::to_string(k);
  out += ",net_x,net_y,magnitude_sum,thrust,power\n";
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.9g", v);
    out += buf;
  };
  for (size_t i = 0; i < s.t.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.6f", s.t[i]);
    out += buf;
    for (int k = 0; k < kNumLinks; ++k) {
      num(s.force[i][k].x());
      num(s.force[i][k].y());
      num(s.f_t[i][k]);
      num(s.f_n[i][k]);
    }
    num(s.net[i].x());
    num(s.net[i].y());
    num(s.magnitude_sum[i]);
    num(s.thrust[i]);
    num(s.power[i]);
    out += "\n";
  }
  return out;
}

}  // namespace wormdrag
