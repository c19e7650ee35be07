// Body geometry of the 13-link chain (docs/conventions.md §1, binding): link numbering, points,
// shape angles, and the rigid pose that best fits a measured frame.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

namespace wormdrag {

inline constexpr int kNumLinks = 13;              // N
inline constexpr int kNumJoints = kNumLinks - 1;  // q_1 … q_{N-1}
inline constexpr int kNumPoints = kNumLinks + 1;  // p_0 … p_N
inline constexpr double kLinkMass = 3.84e-7;      // g per link (paper, Table 1)

using Vec2 = Eigen::Vector2d;
using Points = std::array<Vec2, kNumPoints>;   // p_0 (head tip) … p_N (tail tip)
using Shape = std::array<double, kNumJoints>;  // q_1 … q_{N-1}, radians

// Rigid pose g = (x, y, q0): p_0 in the lab frame and the absolute angle of link 1.
struct Pose {
  double x = 0, y = 0, q0 = 0;
};

// Constant description of the body (MuJoCo-style model: never changes during a run).
struct BodyModel {
  double length = 1.0;           // L, mm
  double link_mass = kLinkMass;  // m, g
  double link_length() const { return length / kNumLinks; }
  double link_inertia() const { return link_mass * link_length() * link_length() / 12.0; }
};

// Relative link angles φ_k = θ_k − q0 (φ_1 = 0) from the shape.
std::array<double, kNumLinks> RelativeLinkAngles(const Shape& q);

// Points of the chain in the head frame (p̂_0 = 0, link 1 along +x).
Points HeadFramePoints(const Shape& q, double link_length);

// Points in the lab frame: p_k = (x,y) + R(q0) p̂_k.
Points LabPoints(const Pose& g, const Shape& q, double link_length);

// Shape of a measured frame: q_k = θ_{k+1} − θ_k wrapped to (−π, π].
Shape ShapeOf(const Points& p);
// Mean distance between consecutive points (the link length of a measured skeleton).
double MeanLinkLength(const Points& p);

// Link angle θ_1 of a measured frame (direction head → tail of link 1).
double HeadLinkAngle(const Points& p);

// The rigid pose that best fits all points of a measured frame, in the least-squares
// sense, for a model chain of the given shape and link length (2-D Procrustes).
// The head link's own angle is the noisiest measurement on real data, so every point
// votes (docs/conventions.md §3).
Pose BestFitPose(const Points& measured, const Shape& q, double link_length);

// Wraps an angle to (−π, π].
double WrapAngle(double a);

// The points in the other order (tail tip first): the same body with head and tail swapped.
Points Reversed(const Points& p);
// Mean distance between corresponding points of two frames.
double MeanPointDistance(const Points& a, const Points& b);
// The same with the order of `b` reversed (head ↔ tail).
double MeanPointDistanceFlipped(const Points& a, const Points& b);

}  // namespace wormdrag
