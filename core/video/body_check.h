// How well a centreline explains the worm's mask: the body re-drawn from the centreline at
// the widths the mask shows along it, compared with the mask. A skeleton that short-cuts
// a touching loop (thinning of a body that touches itself) leaves part of the mask
// unexplained; a body that follows the worm explains all of it. The tracker uses this to
// refuse such frames (docs/video.md, "Turns and coils") and writes the IoU as each
// frame's quality.
#pragma once

#include <array>

#include <opencv2/core.hpp>

#include "core/video/skeleton.h"

namespace wormdrag::video {

struct BodyFit {
  double iou = 0;  // drawn body against the mask
  // Fraction of the mask's area outside the drawn body, in pieces at least 3 px thick.
  double uncovered = 0;
};

// `mask`: the worm's component (0/255); `dist`: its distance transform (CV_32F, as
// cv::distanceTransform gives it). Along the centreline each disc has the mask's local
// half-width, capped at `cap` × the median half-width along it, so that a centreline
// crossing a blob where the body lies on itself does not claim the whole blob.
BodyFit FitToMask(const cv::Mat& mask, const cv::Mat& dist, const Polyline& centreline, double cap = 1.25);

// The body's mean half-width (from `dist`, as above) between 8 % and 16 % of its length
// from each end of `centreline`: {front end, back end}. A worm's tail tapers over its last
// fifth, its head hardly: the wider end is the head.
std::array<double, 2> EndHalfWidths(const cv::Mat& dist, const Polyline& centreline);

}  // namespace wormdrag::video
