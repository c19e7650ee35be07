#include "core/video/rect_filter.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace wormdrag::video {
namespace {

// The same doubles as OpenCV's closing and opening, on noise (every pixel a different
// value, so any misplaced window shows), for windows narrower and wider than the image.
TEST(RectFilter, MatchesOpenCvBitForBit) {
  cv::RNG rng(3);
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(37, 23), cv::Size(1, 9), cv::Size(12, 1)}) {
    cv::Mat src(size, CV_32F);
    rng.fill(src, cv::RNG::UNIFORM, -100.0, 300.0);
    for (const int k : {1, 3, 5, 21, 97, 101}) {
      const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k));
      for (const RectMorph op : {RectMorph::kClose, RectMorph::kOpen}) {
        cv::Mat want;
        cv::morphologyEx(src, want, op == RectMorph::kClose ? cv::MORPH_CLOSE : cv::MORPH_OPEN, kernel,
                         cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
        const cv::Mat got = RectMorphology(src, k, op);
        ASSERT_EQ(got.size(), src.size());
        EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0)
            << size << " k " << k << " close " << (op == RectMorph::kClose);
      }
    }
  }
}

}  // namespace
}  // namespace wormdrag::video
