// Shape modes ordered against the tracking noise: the joint angles of a recording in
// the basis that decorrelates its shape variance from its noise (docs/estimation.md,
// "Smoothing").
//
// Tracking noise on the points reaches the joint angles as a spatially rough pattern
// (each angle is a second difference of the points' normal noise), while a worm's
// shapes are spatially smooth. In the generalized eigenbasis of (shape covariance,
// noise covariance) each mode's noise is white with unit variance and its shape
// variance is the mode's signal-to-noise ratio, so smoothing each mode over time with
// its own GCV-chosen amount removes the noise from the few modes that carry the gait
// without smoothing them more than their own noise requires, and flattens the modes
// that carry only noise. The transform is exact and invertible: with no smoothing the
// joint angles come back unchanged.
#pragma once

#include <Eigen/Core>

#include "core/common/status.h"
#include "core/io/kinematics.h"
#include "core/model/body.h"

namespace wormdrag {

// A mode carries shape when its shape variance clearly exceeds its noise variance
// (pure noise modes scatter around 1 by a few times sqrt(joints / frames)).
inline constexpr double kShapeModeSnr = 2;

struct ShapeModes {
  Eigen::VectorXd mean;        // mean shape over the recording's valid frames, rad
  Eigen::MatrixXd to_modes;    // a = to_modes · (q − mean): noise in a is white, variance 1
  Eigen::MatrixXd from_modes;  // q = mean + from_modes · a (the inverse of to_modes)
  Eigen::VectorXd snr;         // per mode, shape variance over noise variance (ascending)
  // The mode coordinates of joint angles q, and the joint angles of coordinates a.
  Eigen::VectorXd ToModes(const Shape& q) const;
  Shape FromModes(const Eigen::VectorXd& a) const;
};

// The joint angles of frames [start, end) (all valid), unwrapped over time.
void UnwrappedShapes(const Kinematics& k, int start, int end, std::vector<Shape>* q);

// The noise covariance comes from the joint angles' third time differences within
// runs of valid frames (for white noise Δ³q has 20 times its covariance; a smooth gait
// contributes ~ (2π f/fps)³ of its amplitude). Fails when the recording has fewer
// than 4 × (joints + 1) frames in runs of at least 4, too few to estimate either
// covariance.
Result<ShapeModes> NoiseWhitenedModes(const Kinematics& k);

}  // namespace wormdrag
