#include "core/model/body.h"

#include <cmath>

namespace wormdrag {

double WrapAngle(double a) {
  a = std::remainder(a, 2.0 * M_PI);  // in [−π, π]
  if (a <= -M_PI) a += 2.0 * M_PI;
  return a;
}

std::array<double, kNumLinks> RelativeLinkAngles(const Shape& q) {
  std::array<double, kNumLinks> phi{};
  for (int k = 1; k < kNumLinks; ++k) phi[k] = phi[k - 1] + q[k - 1];
  return phi;
}

Points HeadFramePoints(const Shape& q, double link_length) {
  const auto phi = RelativeLinkAngles(q);
  Points p;
  p[0] = Vec2::Zero();
  for (int k = 0; k < kNumLinks; ++k) p[k + 1] = p[k] + link_length * Vec2(std::cos(phi[k]), std::sin(phi[k]));
  return p;
}

Points LabPoints(const Pose& g, const Shape& q, double link_length) {
  const Points ph = HeadFramePoints(q, link_length);
  const double c = std::cos(g.q0), s = std::sin(g.q0);
  Points p;
  for (int k = 0; k < kNumPoints; ++k)
    p[k] = Vec2(g.x + c * ph[k].x() - s * ph[k].y(), g.y + s * ph[k].x() + c * ph[k].y());
  return p;
}

double HeadLinkAngle(const Points& p) {
  const Vec2 d = p[1] - p[0];
  return std::atan2(d.y(), d.x());
}

double MeanLinkLength(const Points& p) {
  double s = 0;
  for (int k = 0; k < kNumLinks; ++k) s += (p[k + 1] - p[k]).norm();
  return s / kNumLinks;
}

Shape ShapeOf(const Points& p) {
  Shape q;
  double prev = HeadLinkAngle(p);
  for (int k = 1; k < kNumLinks; ++k) {
    const Vec2 d = p[k + 1] - p[k];
    const double th = std::atan2(d.y(), d.x());
    q[k - 1] = WrapAngle(th - prev);
    prev = th;
  }
  return q;
}

Pose BestFitPose(const Points& measured, const Shape& q, double link_length) {
  const Points model = HeadFramePoints(q, link_length);
  Vec2 cm = Vec2::Zero(), cd = Vec2::Zero();
  for (int k = 0; k < kNumPoints; ++k) {
    cm += model[k];
    cd += measured[k];
  }
  cm /= kNumPoints;
  cd /= kNumPoints;
  // Rotation angle maximising Σ (R a_k)·b_k: atan2(Σ a×b, Σ a·b).
  double sxx = 0, sxy = 0;
  for (int k = 0; k < kNumPoints; ++k) {
    const Vec2 a = model[k] - cm, b = measured[k] - cd;
    sxx += a.dot(b);
    sxy += a.x() * b.y() - a.y() * b.x();
  }
  Pose g;
  g.q0 = std::atan2(sxy, sxx);
  const double c = std::cos(g.q0), s = std::sin(g.q0);
  // p_0 = cd − R cm (p̂_0 = 0).
  g.x = cd.x() - (c * cm.x() - s * cm.y());
  g.y = cd.y() - (s * cm.x() + c * cm.y());
  return g;
}

Points Reversed(const Points& p) {
  Points r;
  for (int k = 0; k < kNumPoints; ++k) r[k] = p[kNumPoints - 1 - k];
  return r;
}

double MeanPointDistance(const Points& a, const Points& b) {
  double s = 0;
  for (int k = 0; k < kNumPoints; ++k) s += (a[k] - b[k]).norm();
  return s / kNumPoints;
}

double MeanPointDistanceFlipped(const Points& a, const Points& b) {
  double s = 0;
  for (int k = 0; k < kNumPoints; ++k) s += (a[k] - b[kNumPoints - 1 - k]).norm();
  return s / kNumPoints;
}

}  // namespace wormdrag
