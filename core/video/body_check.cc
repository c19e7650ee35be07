#include "core/video/body_check.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace wormdrag::video {

BodyFit FitToMask(const cv::Mat& mask, const cv::Mat& dist, const Polyline& centreline, double cap) {
  BodyFit fit;
  const double length = PolylineLength(centreline);
  const int mask_area = cv::countNonZero(mask);
  if (centreline.size() < 2 || length <= 0 || mask_area == 0) return fit;
  // One disc per pixel of arc: consecutive discs overlap, so the drawn body has no gaps.
  const Polyline p = ResamplePolyline(centreline, std::max(2, static_cast<int>(std::ceil(length)) + 1));
  std::vector<double> r(p.size());
  for (size_t i = 0; i < p.size(); ++i) {
    const int x = std::clamp(static_cast<int>(std::lround(p[i].x())), 0, dist.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(p[i].y())), 0, dist.rows - 1);
    r[i] = dist.at<float>(y, x);
  }
  std::vector<double> sorted = r;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double max_r = cap * sorted[sorted.size() / 2];
  // Work in the box holding the mask and the centreline.
  cv::Rect box = cv::boundingRect(mask);
  for (const Vec2& q : p) box |= cv::Rect(static_cast<int>(q.x()) - 1, static_cast<int>(q.y()) - 1, 3, 3);
  box = (box + cv::Size(2 * static_cast<int>(max_r) + 4, 2 * static_cast<int>(max_r) + 4) -
         cv::Point(static_cast<int>(max_r) + 2, static_cast<int>(max_r) + 2)) &
        cv::Rect(0, 0, mask.cols, mask.rows);
  cv::Mat body = cv::Mat::zeros(box.size(), CV_8U);
  constexpr int kShift = 2;
  for (size_t i = 0; i < p.size(); ++i) {
    // Half a pixel of slack: the distance transform counts to the nearest background
    // pixel's centre, the body's edge lies between the two.
    const double radius = std::min(r[i], max_r) + 0.5;
    const cv::Point c(static_cast<int>(std::lround((p[i].x() - box.x) * (1 << kShift))),
                      static_cast<int>(std::lround((p[i].y() - box.y) * (1 << kShift))));
    cv::circle(body, c, static_cast<int>(std::lround(radius * (1 << kShift))), cv::Scalar(255), -1, cv::LINE_8, kShift);
  }
  const cv::Mat m = mask(box);
  const int inter = cv::countNonZero(m & body);
  const int uni = cv::countNonZero(m | body);
  fit.iou = uni > 0 ? static_cast<double>(inter) / uni : 0;
  // Unexplained mask thinner than 3 px is the outline's jitter around a right body; what
  // survives an opening is a piece of body the centreline does not run through.
  cv::Mat left = m & ~body;
  cv::morphologyEx(left, left, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  fit.uncovered = static_cast<double>(cv::countNonZero(left)) / mask_area;
  return fit;
}

std::array<double, 2> EndHalfWidths(const cv::Mat& dist, const Polyline& centreline) {
  std::array<double, 2> w{0, 0};
  const double length = PolylineLength(centreline);
  if (centreline.size() < 2 || length <= 0) return w;
  constexpr int kSamples = 25;
  const Polyline p = ResamplePolyline(centreline, kSamples * 6 + 1);  // 1/150 of the length apart
  for (int end = 0; end < 2; ++end) {
    double sum = 0;
    int n = 0;
    for (int i = 12; i <= 24; ++i) {  // 8–16 % of 150 steps
      const Vec2& q = p[end == 0 ? i : p.size() - 1 - i];
      const int x = std::clamp(static_cast<int>(std::lround(q.x())), 0, dist.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(q.y())), 0, dist.rows - 1);
      sum += dist.at<float>(y, x);
      ++n;
    }
    w[end] = sum / n;
  }
  return w;
}

}  // namespace wormdrag::video
