// Renders synthetic worm videos with a known skeleton, so the tracker can be scored
// against truth: a tapered body (rounded head, pointed tail) bent by the travelling wave
// q_i(t) = A sin(ωt − k i) + B, crawling forward, drawn with anti-aliasing, then uneven
// illumination, optical blur and Gaussian noise; both polarities.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "core/model/body.h"
#include "core/video/skeleton.h"

namespace wormdrag::video {

struct WormMotion {
  double amplitude = 0.6;    // A, rad per joint of the 13-link body
  double omega = 5.0;        // ω, rad/s (the paper's verification pattern)
  double wave_number = 0.6;  // k, rad per joint index
  double bias = 0.0;         // B, rad
  double body_length_px = 300;
  double speed_px_per_s = 60;  // forward speed of the centroid
  double heading = 0.3;        // rad, direction of travel (tail → head) at t = 0
  double turn_rate = 0.1;      // rad/s, slow rotation of the travel direction
  Vec2 start{320, 240};        // centroid at t = 0, px
};

// Smooth centreline, head first, `samples` points equally spaced in arc: the curvature is
// q(x, t)/(L/13) with q(x, t) = A sin(ωt − k x) + B extended to continuous joint index
// x = 13 s/L, so its 13-link sampling has the given joint angles.
Polyline WormCentreline(const WormMotion& m, double t, int samples = 400);

// The true 14 model points (head → tail) at time t.
Points TrueSkeleton(const WormMotion& m, double t);

// Body radius as a fraction of the largest, at arc fraction s ∈ [0, 1] from the head:
// rounded head cap over 5 %, constant, pointed tail taper over the last 25 %.
double WidthProfile(double s);

struct RenderOptions {
  int width = 640, height = 480;
  double max_radius_px = 0;            // 0: body length / 24 (a worm ~12 times longer than wide)
  bool dark_on_light = true;           // bright-field; false: dark-field (light worm)
  double background = 190, worm = 80;  // grey levels before illumination
  double illumination_gradient = 0.3;  // ±15 % light across the frame, plus a vignette
  double blur_sigma_px = 1.2;
  double noise_sigma = 6;  // grey levels
  std::uint64_t seed = 1;
};

// One 8-bit grayscale frame of the worm whose centreline (head first) is given.
cv::Mat RenderWorm(const Polyline& centreline, const RenderOptions& opt, cv::RNG& rng);

// The imaging steps of RenderWorm on a given coverage image (CV_8U, 255 = body, partial
// values = anti-aliased edge; opt.width × opt.height): worm and background grey levels,
// uneven light, blur, noise.
cv::Mat ShadeCover(const cv::Mat& cover, const RenderOptions& opt, cv::RNG& rng);

}  // namespace wormdrag::video
