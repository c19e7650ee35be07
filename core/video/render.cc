#include "core/video/render.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/io/kinematics.h"

namespace wormdrag::video {

Polyline WormCentreline(const WormMotion& m, double t, int samples) {
  const double L = m.body_length_px, link = L / kNumLinks;
  const double ds = L / (samples - 1);
  Polyline p(samples);
  p[0] = Vec2::Zero();
  double theta = 0;
  for (int i = 1; i < samples; ++i) {
    // Midpoint rule for the heading over the step.
    const double x = kNumLinks * (i - 0.5) * ds / L;
    theta += ds * (m.amplitude * std::sin(m.omega * t - m.wave_number * x) + m.bias) / link;
    p[i] = p[i - 1] + ds * Vec2(std::cos(theta), std::sin(theta));
  }
  // Place it: centroid on the straight path, the tail → head axis along the heading.
  Vec2 c = Vec2::Zero();
  for (const Vec2& q : p) c += q;
  c /= samples;
  const Vec2 axis = p.front() - p.back();
  const double rot = m.heading + m.turn_rate * t - std::atan2(axis.y(), axis.x());
  const double cr = std::cos(rot), sr = std::sin(rot);
  const Vec2 centre = m.start + m.speed_px_per_s * t * Vec2(std::cos(m.heading), std::sin(m.heading));
  for (Vec2& q : p) {
    const Vec2 d = q - c;
    q = centre + Vec2(cr * d.x() - sr * d.y(), sr * d.x() + cr * d.y());
  }
  return p;
}

Points TrueSkeleton(const WormMotion& m, double t) {
  return *ResampleByArcLength(WormCentreline(m, t));
}

double WidthProfile(double s) {
  s = std::clamp(s, 0.0, 1.0);
  constexpr double kHead = 0.05, kTail = 0.25;
  if (s < kHead) {
    const double u = 1 - s / kHead;
    return std::sqrt(std::max(0.0, 1 - u * u));
  }
  if (s > 1 - kTail) return std::pow((1 - s) / kTail, 0.7);
  return 1.0;
}

cv::Mat RenderWorm(const Polyline& c, const RenderOptions& opt, cv::RNG& rng) {
  const int n = static_cast<int>(c.size());
  const double L = PolylineLength(c);
  const double R = opt.max_radius_px > 0 ? opt.max_radius_px : L / 24;
  // Outline: left side head → tail, then right side tail → head.
  constexpr int kShift = 4;
  std::vector<cv::Point> outline(2 * n);
  double s = 0;
  for (int i = 0; i < n; ++i) {
    if (i > 0) s += (c[i] - c[i - 1]).norm();
    const Vec2 t = (c[std::min(i + 1, n - 1)] - c[std::max(i - 1, 0)]).normalized();
    const Vec2 nrm(-t.y(), t.x());
    const double r = R * WidthProfile(s / L);
    auto P = [](const Vec2& v) {
      return cv::Point(static_cast<int>(std::lround(v.x() * (1 << kShift))),
                       static_cast<int>(std::lround(v.y() * (1 << kShift))));
    };
    outline[i] = P(c[i] + r * nrm);
    outline[2 * n - 1 - i] = P(c[i] - r * nrm);
  }
  cv::Mat cover = cv::Mat::zeros(opt.height, opt.width, CV_8U);
  std::vector<std::vector<cv::Point>> polys{outline};
  cv::fillPoly(cover, polys, cv::Scalar(255), cv::LINE_AA, kShift);
  return ShadeCover(cover, opt, rng);
}

cv::Mat ShadeCover(const cv::Mat& cover, const RenderOptions& opt, cv::RNG& rng) {
  cv::Mat img(opt.height, opt.width, CV_32F);
  for (int y = 0; y < opt.height; ++y) {
    float* row = img.ptr<float>(y);
    const uchar* a = cover.ptr<uchar>(y);
    for (int x = 0; x < opt.width; ++x) {
      const double u = static_cast<double>(x) / opt.width - 0.5, v = static_cast<double>(y) / opt.height - 0.5;
      const double light = 1 + opt.illumination_gradient * (u + 0.5 * v) -
                           0.5 * opt.illumination_gradient * (u * u + v * v);
      const double alpha = a[x] / 255.0;
      const double bg = opt.dark_on_light ? opt.background : 255 - opt.background;
      const double fg = opt.dark_on_light ? opt.worm : 255 - opt.worm;
      row[x] = static_cast<float>(light * ((1 - alpha) * bg + alpha * fg));
    }
  }
  if (opt.blur_sigma_px > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), opt.blur_sigma_px);
  if (opt.noise_sigma > 0) {
    cv::Mat noise(img.size(), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0, opt.noise_sigma);
    img += noise;
  }
  cv::Mat out;
  img.convertTo(out, CV_8U);  // saturating
  return out;
}

}  // namespace wormdrag::video
