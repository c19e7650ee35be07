// The image steps of tracking (mask.cc): thresholds, polarity, background removal,
// components and thinning, on images with known answers.
#include "core/video/skeleton.h"

#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/video/render.h"

namespace wormdrag::video {
namespace {

cv::Mat Bar(int w, int h, cv::Rect r) {
  cv::Mat m = cv::Mat::zeros(h, w, CV_8U);
  m(r).setTo(255);
  return m;
}

TEST(Otsu, SplitsTwoLevels) {
  cv::Mat img(50, 50, CV_32F, cv::Scalar(2.0f));
  img(cv::Rect(10, 10, 10, 10)).setTo(10.0f);
  const double t = OtsuThreshold(img);
  EXPECT_GT(t, 2.0);
  EXPECT_LT(t, 10.0);
  EXPECT_EQ(cv::countNonZero(Binarise(img, t)), 100);
}

TEST(Polarity, DetectsBothWays) {
  WormMotion m;
  RenderOptions o;
  cv::RNG rng(3);
  const Polyline c = WormCentreline(m, 0.0);
  o.dark_on_light = true;
  EXPECT_EQ(DetectPolarity(RenderWorm(c, o, rng)), Polarity::kDarkOnLight);
  o.dark_on_light = false;
  EXPECT_EQ(DetectPolarity(RenderWorm(c, o, rng)), Polarity::kLightOnDark);
}

TEST(Response, CancelsAnIlluminationRamp) {
  // A bright ramp with a dark bar: the response is ~0 on the ramp, the bar's depth on it.
  cv::Mat img(100, 200, CV_8U);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 200; ++x) img.at<uchar>(y, x) = static_cast<uchar>(100 + x / 2);
  img(cv::Rect(20, 45, 160, 10)) -= cv::Scalar(60);
  const cv::Mat r = ForegroundResponse(img, Polarity::kDarkOnLight, 31, 0);
  EXPECT_NEAR(r.at<float>(10, 30), 0.0, 1.0);
  EXPECT_NEAR(r.at<float>(10, 170), 0.0, 1.0);
  EXPECT_NEAR(r.at<float>(50, 30), 60.0, 1.0);
  EXPECT_NEAR(r.at<float>(50, 170), 60.0, 1.0);
}

TEST(Components, KeepsTheLargestAndCountsHoles) {
  cv::Mat m = Bar(100, 100, cv::Rect(5, 5, 10, 10));
  m(cv::Rect(30, 30, 40, 40)).setTo(255);
  m(cv::Rect(40, 40, 20, 20)).setTo(0);  // a large hole
  m.at<uchar>(32, 32) = 0;               // a one-pixel hole
  int area = 0;
  cv::Mat big = LargestComponent(m, &area);
  EXPECT_EQ(area, 40 * 40 - 400 - 1);
  EXPECT_EQ(big.at<uchar>(10, 10), 0);
  EXPECT_EQ(FillSmallHoles(big, 10), 1);
  EXPECT_EQ(big.at<uchar>(32, 32), 255);
  EXPECT_EQ(big.at<uchar>(50, 50), 0);
  EXPECT_FALSE(TouchesBorder(big, 1));
  EXPECT_TRUE(TouchesBorder(Bar(50, 50, cv::Rect(0, 10, 5, 5)), 1));
}

TEST(Thinning, BarBecomesItsMidline) {
  const cv::Mat skel = ThinZhangSuen(Bar(80, 40, cv::Rect(10, 15, 60, 11)));  // rows 15..25
  std::vector<cv::Point> px;
  cv::findNonZero(skel, px);
  ASSERT_GT(px.size(), 40u);
  for (const cv::Point& p : px) EXPECT_NEAR(p.y, 20, 1) << p;
  // One pixel wide: no 2×2 block of skeleton pixels.
  for (int y = 0; y + 1 < skel.rows; ++y)
    for (int x = 0; x + 1 < skel.cols; ++x)
      EXPECT_FALSE(skel.at<uchar>(y, x) && skel.at<uchar>(y + 1, x) && skel.at<uchar>(y, x + 1) &&
                   skel.at<uchar>(y + 1, x + 1));
}

}  // namespace
}  // namespace wormdrag::video
