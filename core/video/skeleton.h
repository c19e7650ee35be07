// The per-frame steps of the tracking pipeline (docs/video.md), each a small pure function:
// foreground response and polarity, binarisation, the worm's component, Zhang–Suen thinning,
// the longest path on the skeleton graph, sub-pixel centreline refinement and arc splitting.
// Image coordinates: x = column, y = row, pixel centres at integers.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/model/body.h"

namespace wormdrag::video {

enum class Polarity { kAuto, kDarkOnLight, kLightOnDark };
const char* PolarityName(Polarity p);

// Which way the worm differs from its background, decided from the tail of the residual
// to a large median-filtered background: the worm is a minority of pixels on one side.
// Never returns kAuto.
Polarity DetectPolarity(const cv::Mat& gray8);

// Worm-ness image (CV_32F): ~0 on background, the worm's contrast on the worm, whatever
// the polarity. Background is removed by a morphological closing/opening with a square
// of side `background_kernel_px` (must exceed the worm's width), so uneven illumination
// that varies slowly over that scale cancels. Denoised first by a Gaussian of sigma
// `denoise_sigma_px` (0: none).
cv::Mat ForegroundResponse(const cv::Mat& gray8, Polarity polarity, int background_kernel_px, double denoise_sigma_px);

// Otsu's threshold of a CV_32F image (on 256 bins between its min and max).
double OtsuThreshold(const cv::Mat& response);

// CV_8U mask (0/255) of response > threshold.
cv::Mat Binarise(const cv::Mat& response, double threshold);

// The largest 8-connected component of a mask (0/255); empty mask if none.
// `area` receives its pixel count.
cv::Mat LargestComponent(const cv::Mat& mask, int* area);

// Fills holes (background components not touching the border) smaller than
// `max_hole_area` pixels; returns the number of holes left (larger ones).
int FillSmallHoles(cv::Mat& mask, int max_hole_area);

// True if a foreground pixel lies within `margin` pixels of the image border.
bool TouchesBorder(const cv::Mat& mask, int margin);

// Zhang & Suen (1984) thinning of a 0/255 mask to a one-pixel-wide 8-connected skeleton.
cv::Mat ThinZhangSuen(const cv::Mat& mask);

// The longest geodesic path (8-neighbour steps of 1 and √2) between two skeleton pixels:
// two Dijkstra sweeps, exact on a tree. Pixel coordinates in path order; empty if the
// skeleton is empty.
std::vector<cv::Point> LongestSkeletonPath(const cv::Mat& skeleton);

using Polyline = std::vector<Vec2>;

double PolylineLength(const Polyline& p);
// `n` ≥ 2 points equally spaced along the arc of `p` (endpoints kept).
Polyline ResamplePolyline(const Polyline& p, int n);
// Gaussian smoothing of the coordinates along the index, endpoints held fixed.
Polyline SmoothPolyline(const Polyline& p, double sigma_points);

// Bilinear sample of a CV_32F image (clamped at the border).
double SampleBilinear(const cv::Mat& img, double x, double y);
// Distance from `from` along unit `dir` to where `img` first falls below `threshold`,
// linearly interpolated between samples 0.25 px apart; < 0 if not within `max_dist`.
double DistanceToEdge(const cv::Mat& img, double threshold, const Vec2& from, const Vec2& dir, double max_dist);

struct CentrelineOptions {
  int points = 0;             // working resolution; 0: one point per ~2 px of length
  int refine_iterations = 3;  // normal-midpoint passes
  // Extend a tapered tip to where the linearly extrapolated width reaches 0. Off by
  // default: on the rendered tail (width ∝ distance^0.7) it overshoots by ~8 px.
  bool extrapolate_tips = false;
  // Response level at which a tapered (thin) end stops, below `threshold`; ≤ 0: the same
  // as `threshold`. See ExtendEnd in skeleton.cc.
  double tip_threshold = 0;
};

// From the pixel path to a sub-pixel centreline: smoothed, ends trimmed by the body's
// half-width (thinning leaves forked spurs there), each interior point moved to the
// midpoint between the two body edges along its normal, ends extended by walking along
// the ridge (re-centred between the edges at every 1 px step) to the body's edge in
// `response` at `threshold` (a tapered end on to `opt.tip_threshold`).
// `half_width` is the body's largest half-width in px.
Polyline RefineCentreline(const std::vector<cv::Point>& path, const cv::Mat& response, double threshold,
                          double half_width, const CentrelineOptions& opt);

}  // namespace wormdrag::video
