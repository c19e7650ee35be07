#include "core/sim/shape_drive.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

Shape Wave(double t) {
  Shape q;
  for (int i = 0; i < kNumJoints; ++i) q[i] = 0.5 * std::sin(5 * t - 0.6 * (i + 1)) + 0.1;
  return q;
}

// The Jacobians must give the link-centre velocities that finite differences of
// the head-frame geometry give.
TEST(KnotGeometry, JacobianMatchesFiniteDifferences) {
  BodyModel body;
  body.length = 1.3;
  const double t = 0.37, h = 1e-6;
  Shape q = Wave(t), qp = Wave(t + h), qm = Wave(t - h), qd;
  for (int i = 0; i < kNumJoints; ++i) qd[i] = (qp[i] - qm[i]) / (2 * h);
  const KnotGeometry g = ComputeKnotGeometry(t, q, qd, body);
  // Lab motion: pose moves with body velocity ξ while the shape changes.
  const double xi[3] = {0.3, -0.2, 0.7};
  auto centres = [&](double dt) {
    const Pose pose{xi[0] * dt, xi[1] * dt, xi[2] * dt};  // exact to O(dt²) around 0
    Shape qs = Wave(t + dt);
    Points p = LabPoints(pose, qs, body.link_length());
    std::array<Vec2, kNumLinks> c;
    for (int k = 0; k < kNumLinks; ++k) c[k] = 0.5 * (p[k] + p[k + 1]);
    return c;
  };
  const auto cp = centres(h), cm = centres(-h);
  const auto phi = RelativeLinkAngles(q);
  for (int k = 0; k < kNumLinks; ++k) {
    const Vec2 v = (cp[k] - cm[k]) / (2 * h);
    const Vec2 tan(std::cos(phi[k]), std::sin(phi[k])), nor(-std::sin(phi[k]), std::cos(phi[k]));
    const double vt = g.jx[2 * k] * xi[0] + g.jy[2 * k] * xi[1] + g.jw[2 * k] * xi[2] + g.b[2 * k];
    const double vn = g.jx[2 * k + 1] * xi[0] + g.jy[2 * k + 1] * xi[1] + g.jw[2 * k + 1] * xi[2] + g.b[2 * k + 1];
    EXPECT_NEAR(vt, v.dot(tan), 1e-7) << "link " << k + 1;
    EXPECT_NEAR(vn, v.dot(nor), 1e-7) << "link " << k + 1;
  }
}

TEST(KnotGeometry, MassMatrixOfStraightBody) {
  BodyModel body;
  body.length = 2.0;
  Shape zero{};
  const KnotGeometry g = ComputeKnotGeometry(0, zero, zero, body);
  const double M = kNumLinks * body.link_mass, L = body.length;
  EXPECT_NEAR(g.mass[0], M, 1e-20);
  EXPECT_NEAR(g.mass[2], 0, 1e-20);              // centres on the x axis
  EXPECT_NEAR(g.mass[4], M * L / 2, 1e-18);      // first moment about the head
  EXPECT_NEAR(g.mass[5], M * L * L / 3, 1e-17);  // thin rod about its end
}

}  // namespace
}  // namespace wormdrag
