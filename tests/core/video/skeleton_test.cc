#include "core/video/skeleton.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/video/render.h"

namespace wormdrag::video {
namespace {

TEST(LongestPath, IgnoresASpur) {
  cv::Mat s = cv::Mat::zeros(60, 60, CV_8U);
  cv::line(s, {5, 10}, {50, 10}, 255, 1, cv::LINE_8);   // long arm
  cv::line(s, {50, 10}, {50, 55}, 255, 1, cv::LINE_8);  // long arm
  cv::line(s, {20, 10}, {20, 15}, 255, 1, cv::LINE_8);  // short spur
  const auto path = LongestSkeletonPath(s);
  ASSERT_GE(path.size(), 2u);
  const cv::Point a = path.front(), b = path.back();
  const bool ends_ok = (a == cv::Point(5, 10) && b == cv::Point(50, 55)) ||
                       (b == cv::Point(5, 10) && a == cv::Point(50, 55));
  EXPECT_TRUE(ends_ok) << a << " " << b;
  // 46 + 45 pixels, less the corner the geodesic cuts diagonally.
  EXPECT_EQ(path.size(), 90u);
}

TEST(Polyline, ResamplesToEqualArcs) {
  const Polyline p{{0, 0}, {10, 0}, {10, 5}};
  const Polyline r = ResamplePolyline(p, 7);
  ASSERT_EQ(r.size(), 7u);
  for (size_t i = 1; i < r.size(); ++i) EXPECT_NEAR((r[i] - r[i - 1]).norm(), 2.5, 0.3);
  EXPECT_NEAR(PolylineLength(ResamplePolyline(p, 200)), 15.0, 0.05);
  EXPECT_TRUE(r.back().isApprox(Vec2(10, 5)));
}

TEST(Edges, SubPixelDistance) {
  cv::Mat img(20, 40, CV_32F, cv::Scalar(0));
  for (int x = 0; x < 40; ++x) img.col(x).setTo(x < 20 ? 10.0f : 0.0f);
  // Bilinear ramp between x = 19 (10) and x = 20 (0): 5 at x = 19.5.
  EXPECT_NEAR(DistanceToEdge(img, 5.0, Vec2(10, 10), Vec2(1, 0), 30), 9.5, 0.01);
  EXPECT_LT(DistanceToEdge(img, 5.0, Vec2(10, 10), Vec2(1, 0), 5), 0);
}

// A rendered straight worm along y = 100.3 from x = 50.4 (tail) to 250.4 (head at +x),
// dark on light, noise-free, with the given blur.
cv::Mat StraightWorm(double blur_sigma_px) {
  WormMotion m;
  m.amplitude = 0;
  m.body_length_px = 200;
  m.heading = 0;
  m.turn_rate = 0;
  m.speed_px_per_s = 0;
  m.start = Vec2(150.4, 100.3);
  RenderOptions o;
  o.width = 300;
  o.height = 200;
  o.noise_sigma = 0;
  o.illumination_gradient = 0;
  o.blur_sigma_px = blur_sigma_px;
  cv::RNG rng(1);
  return RenderWorm(WormCentreline(m, 0), o, rng);
}

TEST(Centreline, RecoversAStraightBodyToSubPixel) {
  const cv::Mat img = StraightWorm(RenderOptions{}.blur_sigma_px);
  const cv::Mat resp = ForegroundResponse(img, Polarity::kDarkOnLight, 41, 1.0);
  const double thr = OtsuThreshold(resp);
  int area;
  const cv::Mat mask = LargestComponent(Binarise(resp, thr), &area);
  const auto path = LongestSkeletonPath(ThinZhangSuen(mask));
  const Polyline c = RefineCentreline(path, resp, thr, 200.0 / 24, {});
  for (const Vec2& p : c) EXPECT_NEAR(p.y(), 100.3, 0.25);
  const double x0 = std::min(c.front().x(), c.back().x()), x1 = std::max(c.front().x(), c.back().x());
  EXPECT_NEAR(x0, 50.4, 1.5);
  EXPECT_NEAR(x1, 250.4, 1.5);
}

// Blur hides the thinnest part of a tapered tail below half contrast; a tapered end walks
// on to the lower tip level, a blunt (rounded) head does not move.
TEST(Centreline, TaperedTailReachedUnderBlurBluntHeadKept) {
  const cv::Mat img = StraightWorm(2.0);
  const cv::Mat resp = ForegroundResponse(img, Polarity::kDarkOnLight, 41, 1.0);
  int area;
  const cv::Mat mask = LargestComponent(Binarise(resp, OtsuThreshold(resp)), &area);
  const auto path = LongestSkeletonPath(ThinZhangSuen(mask));
  double contrast;
  cv::minMaxLoc(resp, nullptr, &contrast);
  CentrelineOptions half, tip;
  tip.tip_threshold = 0.35 * contrast;
  const Polyline a = RefineCentreline(path, resp, 0.5 * contrast, 200.0 / 24, half);
  const Polyline b = RefineCentreline(path, resp, 0.5 * contrast, 200.0 / 24, tip);
  auto ends = [](const Polyline& c) {
    return std::pair(std::min(c.front().x(), c.back().x()), std::max(c.front().x(), c.back().x()));
  };
  const auto [tail_a, head_a] = ends(a);
  const auto [tail_b, head_b] = ends(b);
  std::printf("tail end: %.2f at half contrast, %.2f with the tip level (true 50.4); head %.2f / %.2f (true 250.4)\n",
              tail_a, tail_b, head_a, head_b);
  EXPECT_GT(tail_a, 50.4 + 1.5);    // half contrast stops short of the pointed tail
  EXPECT_LT(tail_b, tail_a - 1.0);  // the tip level gets much closer
  EXPECT_NEAR(tail_b, 50.4, 1.3);
  EXPECT_NEAR(head_b, head_a, 1e-9);  // the blunt head is not moved
  EXPECT_NEAR(head_b, 250.4, 1.0);
}

}  // namespace
}  // namespace wormdrag::video
