// The prescribed shape motion of one recording, sampled at the solver's knots, with
// everything that does not depend on the friction coefficients precomputed once:
// per knot the body-frame velocity Jacobians of the 26 link-centre velocity
// components and the body-frame mass matrix and shape momentum. Many coefficient
// sets are then simulated against one ShapeDrive (the MuJoCo "model" side).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"
#include "core/model/body.h"

namespace wormdrag {

// One of the 26 friction terms at a knot: v = J·ξ + b, with ξ = (V_x, V_y, ω) the
// rigid body velocity of the head frame expressed in the head frame.
inline constexpr int kNumTerms = 2 * kNumLinks;  // term 2k: tangential of link k+1, 2k+1: normal

struct KnotGeometry {
  double t = 0;
  std::array<double, kNumTerms> jx{}, jy{}, jw{}, b{};  // J columns and shape velocity
  std::array<double, 6> mass{};                         // body-frame mass matrix, upper triangle: 00 01 02 11 12 22
  std::array<double, 3> shape_momentum{};               // body-frame momentum of the shape motion alone
};

// Most knots one drive may hold. A knot's geometry is 912 bytes, so this bounds a
// drive at about 1.8 GB; at the default 600 knots/s it is 55 min of recording. A frame
// rate far below the recording's real one (e.g. `# fps: 0.001`) asks for millions of
// knots per frame and is refused here instead of exhausting memory or overflowing.
inline constexpr int64_t kMaxKnots = 2'000'000;

// Knots of a drive over `frames` frames (first to last valid) at `substeps` per
// interval, computed without overflow.
inline int64_t KnotCountFor(int64_t frames, int64_t substeps) {
  return frames < 2 ? 1 : (frames - 1) * substeps + 1;
}

struct ShapeDriveOptions {
  // Solver knots per frame interval (≥ 1). Two keep the path within 1e-4 BL of the
  // converged one at 300 fps even where stick–slip switches make ξ(t) nearly jump;
  // one is ~2× faster and within 2e-3 BL there (BENCHMARKS.md).
  int substeps = 2;
};

class ShapeDrive {
 public:
  // Fails if fewer than 2 valid frames exist.
  static Result<ShapeDrive> Build(const Kinematics& k, const BodyModel& body, const ShapeDriveOptions& opt);
  // A drive whose shape is a known function of time (synthetic recordings): every
  // frame valid, the body starting at `initial`.
  using ShapeFunction = std::function<void(double t, Shape* q, Shape* qdot)>;
  static Result<ShapeDrive> FromFunction(const std::vector<double>& frame_times, const ShapeFunction& shape,
                                         const BodyModel& body, const Pose& initial, const ShapeDriveOptions& opt);

  const BodyModel& body() const { return body_; }
  const std::vector<KnotGeometry>& knots() const { return knots_; }
  int substeps() const { return substeps_; }
  // Frames of the recording that are simulated: first_frame() … last_frame(), which
  // are the first and last valid frames. Frame f sits at knot (f − first) · substeps.
  int first_frame() const { return first_frame_; }
  int last_frame() const { return last_frame_; }
  int num_frames() const { return num_frames_; }
  int KnotOfFrame(int f) const { return (f - first_frame_) * substeps_; }
  // The shape at frame f (spline value; equals the measured shape on valid frames).
  const Shape& FrameShape(int f) const { return frame_shapes_[f - first_frame_]; }
  const Pose& initial_pose() const { return initial_pose_; }
  // Measured best-fit pose of a valid frame (used to restart after gaps).
  const Pose& MeasuredPose(int f) const { return measured_poses_[f - first_frame_]; }

 private:
  BodyModel body_;
  int substeps_ = 1;
  int first_frame_ = 0, last_frame_ = 0, num_frames_ = 0;
  std::vector<KnotGeometry> knots_;
  std::vector<Shape> frame_shapes_;
  std::vector<Pose> measured_poses_;
  Pose initial_pose_;
};

// Fills the geometry of one knot from shape q and rate q̇ (pure, tested on its own).
KnotGeometry ComputeKnotGeometry(double t, const Shape& q, const Shape& qdot, const BodyModel& body);

}  // namespace wormdrag
