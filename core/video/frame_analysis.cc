// One frame of tracking (tracker.h): the steps of skeleton.h from the grey image to a
// centreline split into 13 parts, or the reason there is none; and the parameters those
// steps take, resolved from the options and the first frames.
#include "core/video/tracker.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace wormdrag::video {

namespace {

// Median of `img` where `mask` is set, or (`outside`) where it is not, over every
// `step`-th row and column.
double MedianOf(const cv::Mat& img, const cv::Mat& mask, bool outside, int step) {
  std::vector<float> v;
  for (int r = 0; r < img.rows; r += step) {
    const float* row = img.ptr<float>(r);
    const uchar* m = mask.ptr<uchar>(r);
    for (int c = 0; c < img.cols; c += step)
      if ((m[c] != 0) != outside) v.push_back(row[c]);
  }
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

FrameAnalysis AnalyseFrame(const cv::Mat& gray8, const FrameParams& params) {
  FrameAnalysis out;
  const cv::Mat response = ForegroundResponse(gray8, params.polarity, params.background_kernel_px,
                                              params.denoise_sigma_px);
  out.threshold = OtsuThreshold(response);
  int area = 0;
  out.foreground = Binarise(response, out.threshold);
  out.mask = LargestComponent(out.foreground, &area);
  if (area < params.min_area_px) {
    out.reason = MissingReason::kNoWorm;
    return out;
  }
  double tip_threshold = 0;
  if (params.half_contrast) {
    // The edge of a blurred body lies where the response is halfway between background
    // and body; Otsu's split sits higher when the body's brightness varies (textured
    // real worms), which thins the mask.
    // The background is most of the frame: every 3rd row and column gives its median
    // as well, at a ninth of the cost.
    const double body = MedianOf(response, out.mask, false, 1);
    const double background = MedianOf(response, out.mask, true, 3);
    out.threshold = background + 0.5 * (body - background);
    tip_threshold = background + params.mask_fraction * (body - background);
    // The mask (what is worm at all) takes in the dim rim too: a lower fraction.
    out.foreground = Binarise(response, background + params.mask_fraction * (body - background));
    out.mask = LargestComponent(out.foreground, &area);
  }
  out.threshold *= params.threshold_scale;
  // The worm's box with a ring of background: distances and holes within it are those of
  // the whole frame, at a fraction of the cost.
  const cv::Rect worm_box = (cv::boundingRect(out.mask) + cv::Size(2, 2) - cv::Point(1, 1)) &
                            cv::Rect(0, 0, gray8.cols, gray8.rows);
  cv::Mat dist = cv::Mat::zeros(gray8.size(), CV_32F);
  cv::Mat dist_box = dist(worm_box);
  cv::distanceTransform(out.mask(worm_box), dist_box, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  double max_dist;
  cv::minMaxLoc(dist_box, nullptr, &max_dist);
  out.half_width_px = max_dist;
  // Holes up to a body width across are noise; a larger one is the space inside a coil.
  const int max_hole = std::max(4, static_cast<int>(std::ceil(max_dist * max_dist)));
  cv::Mat mask_box = out.mask(worm_box);
  const int holes = FillSmallHoles(mask_box, max_hole);
  if (params.reject_border && TouchesBorder(out.mask, params.border_margin_px)) {
    out.reason = MissingReason::kTouchesBorder;
    return out;
  }
  if (holes > 0) {
    out.reason = MissingReason::kCoiled;
    return out;
  }
  // Thin a slightly smoothed copy of the component's neighbourhood: a jagged outline
  // grows spurs on the skeleton.
  const cv::Rect box = cv::boundingRect(out.mask);
  const cv::Rect roi = (box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, gray8.cols, gray8.rows);
  cv::Mat smooth;
  cv::GaussianBlur(out.mask(roi), smooth, cv::Size(0, 0), 1.0);
  cv::threshold(smooth, smooth, 127, 255, cv::THRESH_BINARY);
  const cv::Mat skeleton = ThinZhangSuen(smooth);
  std::vector<cv::Point> path = LongestSkeletonPath(skeleton);
  for (cv::Point& p : path) p += roi.tl();
  if (path.size() < 3) {
    out.reason = MissingReason::kSkeletonFailed;
    return out;
  }
  CentrelineOptions copt;
  copt.extrapolate_tips = params.extrapolate_tips;
  // A tapered tail ends where the mask ends (see ExtendEnd).
  if (params.tapered_tips) copt.tip_threshold = tip_threshold * params.threshold_scale;
  out.centreline = RefineCentreline(path, response, out.threshold, out.half_width_px, copt);
  out.length_px = PolylineLength(out.centreline);
  // A body at least 3 widths long is the least a worm can be; shorter is a blob.
  if (out.centreline.size() < 3 || out.length_px < 6 * out.half_width_px) {
    out.reason = MissingReason::kSkeletonFailed;
    out.centreline.clear();
    return out;
  }
  out.fit = FitToMask(out.mask, dist, out.centreline);
  if (out.fit.uncovered > params.max_unexplained) {
    out.reason = MissingReason::kTouching;
    out.centreline.clear();
    return out;
  }
  out.reason = MissingReason::kNone;
  return out;
}

FrameParams ResolveParams(const TrackOptions& opt, const std::vector<cv::Mat>& first_frames) {
  FrameParams p;
  p.denoise_sigma_px = opt.denoise_sigma_px;
  p.threshold_scale = opt.threshold_scale;
  p.half_contrast = opt.half_contrast;
  p.mask_fraction = opt.mask_fraction;
  p.min_area_px = opt.min_area_px;
  p.reject_border = opt.reject_border;
  p.border_margin_px = opt.border_margin_px;
  p.max_unexplained = opt.max_unexplained;
  p.extrapolate_tips = opt.extrapolate_tips;
  p.tapered_tips = opt.tapered_tips;
  const cv::Mat& f0 = first_frames.empty() ? cv::Mat() : first_frames.front();
  p.background_kernel_px = opt.background_kernel_px > 0 ? opt.background_kernel_px
                                                        : std::clamp(std::min(f0.rows, f0.cols) / 5, 15, 101);
  p.polarity = opt.polarity;
  if (p.polarity == Polarity::kAuto) {
    int dark = 0, light = 0;
    for (const cv::Mat& f : first_frames) (DetectPolarity(f) == Polarity::kDarkOnLight ? dark : light)++;
    p.polarity = dark >= light ? Polarity::kDarkOnLight : Polarity::kLightOnDark;
  }
  return p;
}

}  // namespace wormdrag::video
