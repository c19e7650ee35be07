// Grey-level closing and opening with a square window, as cv::morphologyEx with a
// MORPH_RECT kernel and BORDER_REPLICATE computes them, bit for bit, at a cost that does
// not grow with the window: the background filter of tracking (skeleton.h) spans
// ~100 px, where OpenCV's separable filter compares every pixel with the whole window.
#pragma once

#include <opencv2/core.hpp>

namespace wormdrag::video {

enum class RectMorph { kClose, kOpen };

// `src` (CV_32F) closed or opened with a k × k square (k odd, ≥ 1) centred on each pixel.
cv::Mat RectMorphology(const cv::Mat& src, int k, RectMorph op);

}  // namespace wormdrag::video
