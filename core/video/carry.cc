#include "core/video/carry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "core/io/kinematics.h"
#include "core/video/orient.h"

namespace wormdrag::video {
namespace {

// A polyline with its cumulative arc length, sampled at any arc position.
class Track {
 public:
  explicit Track(Polyline p) : p_(std::move(p)), s_(p_.size(), 0.0) {
    for (size_t i = 1; i < p_.size(); ++i) s_[i] = s_[i - 1] + (p_[i] - p_[i - 1]).norm();
  }
  double length() const { return s_.back(); }
  Vec2 At(double x) const {
    const size_t k = std::upper_bound(s_.begin(), s_.end(), x) - s_.begin();
    const size_t j = std::clamp<size_t>(k, 1, p_.size() - 1) - 1;
    const double f = std::clamp((x - s_[j]) / std::max(1e-12, s_[j + 1] - s_[j]), 0.0, 1.0);
    return (1 - f) * p_[j] + f * p_[j + 1];
  }
  // The stretch [head − length, head], head first, one point per ~2 px.
  Polyline Body(double head, double length) const {
    const int n = std::max(8, static_cast<int>(length / 2));
    Polyline b(n);
    for (int i = 0; i < n; ++i) b[i] = At(head - length * i / (n - 1));
    return b;
  }

 private:
  Polyline p_;
  std::vector<double> s_;
};

// A frame's body head first, as finely as it was measured: its sub-pixel centreline
// turned to match its points (a tight loop is poorly drawn by 14 points' chords).
Polyline HeadFirst(const FrameTrack& f) {
  if (f.centreline.size() < kNumPoints) return Polyline(f.px.begin(), f.px.end());
  Polyline c = f.centreline;
  if ((c.front() - f.px[0]).norm() > (c.back() - f.px[0]).norm()) std::reverse(c.begin(), c.end());
  return c;
}

// The track from `a`'s tail through its head on to `b`'s head, whose head lies `advance`
// px beyond `a`'s along it: `a` tail first, then the part of `b` ahead of `a`'s head.
Track TrackThrough(const FrameTrack& a, const FrameTrack& b, double advance) {
  Polyline p = HeadFirst(a);
  std::reverse(p.begin(), p.end());
  const Polyline pb = HeadFirst(b);
  // Join where `b` passes nearest to `a`'s head, about `advance` from `b`'s head: joining
  // at the estimated advance alone leaves a kink of its error at the joint.
  std::vector<double> arc(pb.size(), 0.0);  // from b's head
  for (size_t i = 1; i < pb.size(); ++i) arc[i] = arc[i - 1] + (pb[i] - pb[i - 1]).norm();
  const Vec2 head = p.back();
  size_t join = 0;
  double nearest = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < pb.size(); ++i) {
    if (std::abs(arc[i] - advance) > 0.1 * arc.back()) continue;
    if ((pb[i] - head).norm() < nearest) {
      nearest = (pb[i] - head).norm();
      join = i;
    }
  }
  for (size_t i = join; i-- > 0;) p.push_back(pb[i]);
  return Track(std::move(p));
}

struct MaskView {
  const cv::Mat& mask;  // crop, 0/255
  cv::Mat dist;         // its distance transform, the crop's outside counted as background
  cv::Point offset;
  bool Inside(const Vec2& q, double* d) const {
    const int x = static_cast<int>(std::lround(q.x())) - offset.x, y = static_cast<int>(std::lround(q.y())) - offset.y;
    if (x < 0 || y < 0 || x >= mask.cols || y >= mask.rows || !mask.at<uchar>(y, x)) return false;
    *d = dist.at<float>(y, x);
    return true;
  }
};

// How well a body lies on the mask: each sample on it scores its distance to the edge
// (capped: a body crossing itself is wider there), each sample off it the cap's loss.
double Score(const Polyline& body, const MaskView& v, double cap, double* inside) {
  double score = 0;
  int in = 0;
  for (const Vec2& q : body) {
    double d = 0;
    if (v.Inside(q, &d)) {
      score += std::min(d, cap);
      ++in;
    } else {
      score -= cap;
    }
  }
  *inside = static_cast<double>(in) / body.size();
  return score;
}

// Carries the body into frame `f`: the stretch of `track` of `length` whose head, between
// `head_lo` and `head_hi`, fits the mask best; false (frame unchanged) when that body
// does not explain the mask.
bool CarryOne(FrameTrack& f, const Track& track, double length, double head_lo, double head_hi,
              const CarryOptions& opt) {
  cv::Mat padded;
  cv::copyMakeBorder(f.mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat dist;
  cv::distanceTransform(padded, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const MaskView view{f.mask, dist(cv::Rect(1, 1, f.mask.cols, f.mask.rows)), f.mask_offset};
  const double cap = length / 30;  // under the half-width of a body ~12 widths long
  double best = -1e300, best_head = head_lo, inside = 0;
  for (double h = head_lo; h <= head_hi + 1e-9; h += 0.5) {
    double in = 0;
    const double s = Score(track.Body(h, length), view, cap, &in);
    if (s > best) {
      best = s;
      best_head = h;
      inside = in;
    }
  }
  if (inside < opt.min_inside) return false;
  Polyline body = track.Body(best_head, length);
  for (Vec2& q : body) q -= Vec2(f.mask_offset.x, f.mask_offset.y);
  const BodyFit fit = FitToMask(f.mask, view.dist, body);
  if (fit.uncovered > opt.max_unexplained) return false;
  Result<Points> pts = ResampleByArcLength(track.Body(best_head, length));
  if (!pts.ok()) return false;
  f.px = *pts;
  f.length_px = length;
  f.fit = fit;
  f.carried = true;
  f.reason = MissingReason::kNone;
  return true;
}

}  // namespace

int CarryThroughCoils(std::vector<FrameTrack>& frames, const CarryOptions& opt) {
  int carried = 0;
  const int n = static_cast<int>(frames.size());
  for (int a = 0; a < n; ++a) {
    if (!frames[a].valid()) continue;
    int b = a + 1;
    while (b < n && !frames[b].valid() && !frames[b].mask.empty()) ++b;
    if (b >= n || b == a + 1 || !frames[b].valid() || b - a - 1 > opt.max_gap) continue;
    FrameTrack fa = frames[a], fb = frames[b];
    // Only when the body after lies on the body before, in the orientation written.
    double advance = 0;
    const double slide = 0.75 * fa.length_px;
    const double same = SlideCost(fa.px, fb.px, slide, &advance);
    const double flip = SlideCost(fa.px, Reversed(fb.px), slide);
    if (!(same < fa.length_px / 10 && same < 0.5 * flip)) continue;
    // A worm backing up lays its track tail first: carry its bodies tail first.
    const bool backing = advance < 0;
    if (backing) {
      fa.px = Reversed(fa.px);
      fb.px = Reversed(fb.px);
      SlideCost(fa.px, fb.px, slide, &advance);
    }
    const Track track = TrackThrough(fa, fb, advance);
    // The head moves along the track from a's head (arc La) to b's (La + advance). Where
    // the body lies on itself every stretch of the track near the true one stays on the
    // mask, and the best fit drifts toward where the thin tail tip sits on thick body; so
    // each frame's head is sought only near the steady pace from a to b (within half a
    // frame's advance, at least 2 px, either way).
    const double pace = advance / (b - a);
    const double window = std::max(2.0, 0.5 * std::abs(pace));
    for (int i = a + 1; i < b; ++i) {
      const double u = static_cast<double>(i - a) / (b - a);
      const double length = (1 - u) * fa.length_px + u * fb.length_px;
      const double expected = fa.length_px + u * advance;
      const double lo = std::max(length, expected - window), hi = std::min(track.length(), expected + window);
      if (lo > hi) continue;
      if (!CarryOne(frames[i], track, length, lo, hi, opt)) continue;
      if (backing) frames[i].px = Reversed(frames[i].px);
      ++carried;
    }
    a = b - 1;
  }
  for (FrameTrack& f : frames) f.mask.release();
  return carried;
}

}  // namespace wormdrag::video
