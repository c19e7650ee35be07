#include "core/video/body_check.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/video/render.h"

namespace wormdrag::video {
namespace {

// A mask of the rendered body (rounded head, tail tapered over its last quarter) along
// `c`, radius `r` at its widest, and its distance transform.
void BodyMask(const Polyline& c, double r, cv::Mat* mask, cv::Mat* dist) {
  *mask = cv::Mat::zeros(480, 640, CV_8U);
  const Polyline p = ResamplePolyline(c, 600);
  for (size_t i = 0; i < p.size(); ++i) {
    const double w = r * WidthProfile(static_cast<double>(i) / (p.size() - 1));
    if (w < 0.5) continue;
    cv::circle(*mask, cv::Point(static_cast<int>(std::lround(p[i].x())), static_cast<int>(std::lround(p[i].y()))),
               static_cast<int>(std::lround(w)), cv::Scalar(255), -1);
  }
  cv::distanceTransform(*mask, *dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
}

TEST(BodyCheck, RightCentrelineExplainsTheMaskAShortCutDoesNot) {
  WormMotion m;
  const Polyline c = WormCentreline(m, 0.3);
  cv::Mat mask, dist;
  BodyMask(c, 12.5, &mask, &dist);
  const BodyFit right = FitToMask(mask, dist, c);
  EXPECT_LT(right.uncovered, 0.01);
  EXPECT_GT(right.iou, 0.85);
  // A centreline that stops halfway leaves the other half unexplained.
  const Polyline half(c.begin(), c.begin() + c.size() / 2);
  EXPECT_GT(FitToMask(mask, dist, half).uncovered, 0.3);
  // One that cuts straight across a bend from head to tail leaves the bends out.
  const Polyline chord = {c.front(), c.back()};
  EXPECT_GT(FitToMask(mask, dist, chord).uncovered, 0.1);
}

TEST(BodyCheck, EndHalfWidthsSeeTheTaperedTail) {
  WormMotion m;
  const Polyline c = WormCentreline(m, 0.0);  // head first
  cv::Mat mask, dist;
  BodyMask(c, 12.5, &mask, &dist);
  const std::array<double, 2> w = EndHalfWidths(dist, c);
  // The rendered tail tapers over its last quarter: at 8–16 % from its tip it is
  // (0.32–0.64)^0.7 of the full width; the head is full width there.
  EXPECT_GT(w[0], 10.0);
  EXPECT_LT(w[1], 0.8 * w[0]);
  const Polyline reversed(c.rbegin(), c.rend());
  const std::array<double, 2> r = EndHalfWidths(dist, reversed);
  EXPECT_DOUBLE_EQ(r[0], w[1]);
}

}  // namespace
}  // namespace wormdrag::video
