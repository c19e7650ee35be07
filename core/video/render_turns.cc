#include "core/video/render_turns.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/io/kinematics.h"

namespace wormdrag::video {

TurnMotion DeltaTurn() {
  return TurnMotion{};
}

TurnMotion OmegaTurn() {
  TurnMotion m;
  m.turn_angle = 1.15 * M_PI;
  m.turn_arc_bl = 0.45;
  m.turn_start_bl = 0.3;
  m.reversal_s = 1.0;
  m.reversal_at_s = 1.0;
  return m;
}

TurnMotion Hairpin() {
  TurnMotion m;
  m.turn_angle = M_PI;
  m.turn_arc_bl = 0.2;
  return m;
}

namespace {

// Heading of the track at arc `s` (px): the crawl's sinuous swing plus the turn, whose
// curvature is constant over its arc.
double TrackHeading(const TurnMotion& m, double s) {
  const double L = m.body_length_px;
  const double u = std::clamp((s - m.turn_start_bl * L) / (m.turn_arc_bl * L), 0.0, 1.0);
  return m.heading + m.wave_amplitude * std::sin(2 * M_PI * s / (m.wavelength_bl * L)) + m.turn_angle * u;
}

}  // namespace

TurnTrack::TurnTrack(const TurnMotion& m) : m_(m) {
  const double L = m.body_length_px;
  // Behind the start: a body length plus what a reversal backs; ahead: generous room.
  const double behind = L + m.reversal_s * m.speed_px_per_s + L;
  const double ahead = 8 * L;
  const int n0 = static_cast<int>(std::ceil(behind / step_));
  const int n1 = static_cast<int>(std::ceil(ahead / step_));
  arc0_ = -n0 * step_;
  track_.assign(n0 + n1 + 1, Vec2::Zero());
  track_[n0] = m.start;
  for (int i = n0 + 1; i <= n0 + n1; ++i) {
    const double th = TrackHeading(m, arc0_ + (i - 0.5) * step_);
    track_[i] = track_[i - 1] + step_ * Vec2(std::cos(th), std::sin(th));
  }
  for (int i = n0 - 1; i >= 0; --i) {
    const double th = TrackHeading(m, arc0_ + (i + 0.5) * step_);
    track_[i] = track_[i + 1] - step_ * Vec2(std::cos(th), std::sin(th));
  }
}

double TurnTrack::HeadArc(double t) const {
  const double v = m_.speed_px_per_s;
  // Distance at steady speed, then the integral of the pace's sinusoidal part.
  const double w = 2 * M_PI / m_.pace_period_s;
  const double uneven = m_.pace_variation * v * (1 - std::cos(w * t)) / w;
  if (m_.reversal_s <= 0 || t <= m_.reversal_at_s) return v * t + uneven;
  if (t <= m_.reversal_at_s + m_.reversal_s) return v * (2 * m_.reversal_at_s - t) + uneven;
  return v * (t - 2 * m_.reversal_s) + uneven;
}

Vec2 TurnTrack::At(double arc) const {
  const double x = std::clamp((arc - arc0_) / step_, 0.0, static_cast<double>(track_.size() - 1));
  const size_t i = std::min(static_cast<size_t>(x), track_.size() - 2);
  const double f = x - i;
  return (1 - f) * track_[i] + f * track_[i + 1];
}

Polyline TurnTrack::Centreline(double t, int samples) const {
  const double head = HeadArc(t), L = m_.body_length_px;
  Polyline p(samples);
  for (int i = 0; i < samples; ++i) p[i] = At(head - L * i / (samples - 1));
  return p;
}

Points TurnTrack::Skeleton(double t) const {
  return *ResampleByArcLength(Centreline(t));
}

cv::Mat RenderOverlappingWorm(const Polyline& c, const RenderOptions& opt, cv::RNG& rng) {
  constexpr int kScale = 4;
  const int n = static_cast<int>(c.size());
  const double L = PolylineLength(c);
  const double R = opt.max_radius_px > 0 ? opt.max_radius_px : L / 24;
  cv::Mat big = cv::Mat::zeros(opt.height * kScale, opt.width * kScale, CV_8U);
  // Pixel centres at integers: a point x maps to the fine pixel centre (x + ½)·k − ½.
  auto P = [](const Vec2& v) {
    return cv::Point(static_cast<int>(std::lround((v.x() + 0.5) * kScale - 0.5)),
                     static_cast<int>(std::lround((v.y() + 0.5) * kScale - 0.5)));
  };
  std::vector<double> r(n);
  double s = 0;
  for (int i = 0; i < n; ++i) {
    if (i > 0) s += (c[i] - c[i - 1]).norm();
    r[i] = R * WidthProfile(s / L);
  }
  for (int i = 0; i + 1 < n; ++i) {
    const Vec2 d = c[i + 1] - c[i];
    if (d.norm() == 0) continue;
    const Vec2 nrm = Vec2(-d.y(), d.x()).normalized();
    const cv::Point quad[4] = {P(c[i] + r[i] * nrm), P(c[i + 1] + r[i + 1] * nrm), P(c[i + 1] - r[i + 1] * nrm),
                               P(c[i] - r[i] * nrm)};
    cv::fillConvexPoly(big, quad, 4, cv::Scalar(255));
  }
  // Discs fill the outer side of each bend between two segments.
  for (int i = 0; i < n; ++i)
    if (r[i] * kScale >= 1) cv::circle(big, P(c[i]), static_cast<int>(std::lround(r[i] * kScale)), cv::Scalar(255), -1);
  cv::Mat cover;
  cv::resize(big, cover, cv::Size(opt.width, opt.height), 0, 0, cv::INTER_AREA);
  return ShadeCover(cover, opt, rng);
}

double JointAngleRms(const Points& a, const Points& b) {
  const Shape qa = ShapeOf(a), qb = ShapeOf(b);
  double s = 0;
  for (int k = 0; k < kNumJoints; ++k) {
    const double d = WrapAngle(qa[k] - qb[k]);
    s += d * d;
  }
  return std::sqrt(s / kNumJoints);
}

}  // namespace wormdrag::video
