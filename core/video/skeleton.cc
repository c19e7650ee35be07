// The centreline steps of tracking (skeleton.h): the longest path on the thinned
// mask, polyline resampling and smoothing, the walk out to the body's tips, and the
// distances between point sets. The image steps are in mask.cc.
#include "core/video/skeleton.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace wormdrag::video {

namespace {

// Dijkstra over skeleton pixels from `src`; returns the farthest pixel index and fills
// distances and predecessors (indices into `pixels`).
int Farthest(const std::vector<cv::Point>& pixels, const cv::Mat& index, int src, std::vector<double>& dist,
             std::vector<int>& prev) {
  dist.assign(pixels.size(), std::numeric_limits<double>::infinity());
  prev.assign(pixels.size(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
  dist[src] = 0;
  pq.emplace(0.0, src);
  while (!pq.empty()) {
    auto [d, u] = pq.top();
    pq.pop();
    if (d > dist[u]) continue;
    const cv::Point p = pixels[u];
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (!dx && !dy) continue;
        const int x = p.x + dx, y = p.y + dy;
        if (x < 0 || y < 0 || x >= index.cols || y >= index.rows) continue;
        const int v = index.at<int>(y, x);
        if (v < 0) continue;
        const double nd = d + ((dx && dy) ? M_SQRT2 : 1.0);
        if (nd < dist[v]) {
          dist[v] = nd;
          prev[v] = u;
          pq.emplace(nd, v);
        }
      }
  }
  int best = src;
  for (size_t i = 0; i < pixels.size(); ++i)
    if (std::isfinite(dist[i]) && dist[i] > dist[best]) best = static_cast<int>(i);
  return best;
}

}  // namespace

std::vector<cv::Point> LongestSkeletonPath(const cv::Mat& skeleton) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(skeleton, pixels);
  if (pixels.empty()) return {};
  cv::Mat index(skeleton.size(), CV_32S, cv::Scalar(-1));
  for (size_t i = 0; i < pixels.size(); ++i) index.at<int>(pixels[i]) = static_cast<int>(i);
  std::vector<double> dist;
  std::vector<int> prev;
  const int a = Farthest(pixels, index, 0, dist, prev);
  const int b = Farthest(pixels, index, a, dist, prev);
  std::vector<cv::Point> path;
  for (int v = b; v >= 0; v = prev[v]) path.push_back(pixels[v]);
  return path;  // from b to a
}

double PolylineLength(const Polyline& p) {
  double s = 0;
  for (size_t i = 1; i < p.size(); ++i) s += (p[i] - p[i - 1]).norm();
  return s;
}

Polyline ResamplePolyline(const Polyline& p, int n) {
  if (p.size() < 2 || n < 2) return p;
  std::vector<double> s(p.size(), 0.0);
  for (size_t i = 1; i < p.size(); ++i) s[i] = s[i - 1] + (p[i] - p[i - 1]).norm();
  const double total = s.back();
  Polyline out(n);
  size_t j = 1;
  for (int k = 0; k < n; ++k) {
    const double target = total * k / (n - 1);
    while (j < p.size() - 1 && s[j] < target) ++j;
    const double seg = s[j] - s[j - 1];
    const double u = seg > 0 ? std::clamp((target - s[j - 1]) / seg, 0.0, 1.0) : 0.0;
    out[k] = p[j - 1] + u * (p[j] - p[j - 1]);
  }
  out.front() = p.front();
  out.back() = p.back();
  return out;
}

Polyline SmoothPolyline(const Polyline& p, double sigma) {
  if (sigma <= 0 || p.size() < 3) return p;
  const int half = static_cast<int>(std::ceil(3 * sigma));
  Polyline out(p.size());
  const int n = static_cast<int>(p.size());
  for (int i = 0; i < n; ++i) {
    // Shrink the window near the ends so that it stays symmetric: the ends do not drift.
    const int h = std::min({half, i, n - 1 - i});
    Vec2 acc = Vec2::Zero();
    double wsum = 0;
    for (int j = -h; j <= h; ++j) {
      const double w = std::exp(-0.5 * j * j / (sigma * sigma));
      acc += w * p[i + j];
      wsum += w;
    }
    out[i] = acc / wsum;
  }
  return out;
}

double SampleBilinear(const cv::Mat& img, double x, double y) {
  x = std::clamp(x, 0.0, img.cols - 1.0);
  y = std::clamp(y, 0.0, img.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), img.cols - 2 < 0 ? 0 : img.cols - 2);
  const int y0 = std::min(static_cast<int>(y), img.rows - 2 < 0 ? 0 : img.rows - 2);
  const int x1 = std::min(x0 + 1, img.cols - 1), y1 = std::min(y0 + 1, img.rows - 1);
  const double fx = x - x0, fy = y - y0;
  const double a = img.at<float>(y0, x0), b = img.at<float>(y0, x1);
  const double c = img.at<float>(y1, x0), d = img.at<float>(y1, x1);
  return (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d);
}

double DistanceToEdge(const cv::Mat& img, double threshold, const Vec2& from, const Vec2& dir, double max_dist) {
  constexpr double kStep = 0.25;
  double prev_v = SampleBilinear(img, from.x(), from.y());
  if (prev_v <= threshold) return 0;
  for (double t = kStep; t <= max_dist; t += kStep) {
    const Vec2 q = from + t * dir;
    if (q.x() < 0 || q.y() < 0 || q.x() > img.cols - 1 || q.y() > img.rows - 1) return t;
    const double v = SampleBilinear(img, q.x(), q.y());
    if (v <= threshold) return t - kStep + kStep * (prev_v - threshold) / (prev_v - v);
    prev_v = v;
  }
  return -1;
}

namespace {

Vec2 UnitNormal(const Polyline& p, size_t i) {
  const size_t a = i == 0 ? 0 : i - 1, b = std::min(i + 1, p.size() - 1);
  Vec2 t = p[b] - p[a];
  const double n = t.norm();
  if (n == 0) return Vec2(0, 0);
  t /= n;
  return Vec2(-t.y(), t.x());
}

// Extends the end `p.back()` to the body's tip by following the ridge: step 1 px along
// the local direction, re-centre the step between the body's edges, until the next step
// would leave the body; the last piece ends at the sub-pixel edge. Following the ridge
// (rather than a straight tangent) keeps a strongly bent head on the body.
// `half_widths` holds the measured half-width at each point (< 0 unknown); with
// `extrapolate`, a tip that tapers nearly to nothing at its visible edge is extended on to
// where the linearly extrapolated half-width reaches 0 (blur hides the thinnest part).
// `tip_threshold` (< threshold, or ≤ 0 for none): a *tapered* end — one whose measured
// half-width over the last few px of the walk is under a third of the body's — walks on
// down to this lower level. Blur spreads a thin tip's contrast over a width of ~2σ, so its
// thinnest part never reaches half contrast and the half-contrast end lies short of the
// true tip, the more so the stronger the blur; a blunt end (the head's rounded cap) keeps
// the half-contrast edge, which is where a blurred wide edge truly lies.
void ExtendEnd(Polyline& p, std::vector<double>& half_widths, const cv::Mat& response, double threshold,
               double tip_threshold, double half_width, bool extrapolate) {
  if (p.size() < 3) return;
  // Direction over about one half-width: shorter windows let the lateral re-centring
  // steer the direction and the walk veers off at a blunt tip.
  const double window = std::max(4.0, half_width);
  auto direction = [&]() {
    double along = 0;
    size_t j = p.size() - 1;
    while (j > 0 && along < window) {
      along += (p[j] - p[j - 1]).norm();
      --j;
    }
    Vec2 d = p.back() - p[j];
    return d.norm() > 0 ? Vec2(d.normalized()) : Vec2(Vec2::Zero());
  };
  const int max_steps = static_cast<int>(4 * half_width) + 10;
  Vec2 dir = direction();
  if (dir.norm() == 0) return;
  auto walk = [&](double level) {
    for (int step = 0; step < max_steps; ++step) {
      const Vec2 next = p.back() + dir;
      if (SampleBilinear(response, next.x(), next.y()) <= level) break;
      const Vec2 nrm(-dir.y(), dir.x());
      const double a = DistanceToEdge(response, level, next, nrm, 1.5 * half_width + 2);
      const double b = DistanceToEdge(response, level, next, -nrm, 1.5 * half_width + 2);
      Vec2 centred = next;
      double hw = -1;
      if (a >= 0 && b >= 0) {
        centred = next + std::clamp(0.5 * (a - b), -0.3, 0.3) * nrm;
        // Only half-widths at the main level are comparable with the body's.
        if (level == threshold) hw = 0.5 * (a + b);
      }
      p.push_back(centred);
      half_widths.push_back(hw);
      dir = direction();
    }
  };
  walk(threshold);
  if (tip_threshold > 0 && tip_threshold < threshold) {
    // Mean measured half-width 1.5–5 px behind the end: the head's rounded cap is still
    // over half the body's width there, a tapered tail under a sixth.
    double along = 0, sum = 0;
    int count = 0;
    for (size_t j = p.size() - 1; j > 0 && along < 5.0; --j) {
      if (along >= 1.5 && half_widths[j] >= 0) {
        sum += half_widths[j];
        ++count;
      }
      along += (p[j] - p[j - 1]).norm();
    }
    if (count > 0 && sum / count < half_width / 3) {
      walk(tip_threshold);
      threshold = tip_threshold;
    }
  }
  double ext = DistanceToEdge(response, threshold, p.back(), dir, 2.0);
  if (ext < 0) ext = 0;
  if (extrapolate) {
    // Least-squares line of half-width against arc position over the last three
    // half-widths of measured widths; where it reaches 0 is the tip.
    const int n = static_cast<int>(p.size());
    std::vector<double> s_list, w_list;
    double s = 0;
    for (int i = n - 1; i > 0 && s < 3 * half_width; --i) {
      if (half_widths[i] > 0) {
        s_list.push_back(-s);
        w_list.push_back(half_widths[i]);
      }
      s += (p[i] - p[i - 1]).norm();
    }
    if (s_list.size() >= 4) {
      double ms = 0, mw = 0;
      for (size_t i = 0; i < s_list.size(); ++i) {
        ms += s_list[i];
        mw += w_list[i];
      }
      ms /= s_list.size();
      mw /= s_list.size();
      double sxx = 0, sxy = 0;
      for (size_t i = 0; i < s_list.size(); ++i) {
        sxx += (s_list[i] - ms) * (s_list[i] - ms);
        sxy += (s_list[i] - ms) * (w_list[i] - mw);
      }
      if (sxx > 0 && sxy < 0) {
        const double slope = sxy / sxx;
        const double zero = ms - mw / slope;  // arc position (0 = current end) of w = 0
        const double width_at_edge = mw + slope * (ext - ms);
        // Only a tip nearly closed at its visible edge (under a third of the body's
        // half-width) moves, and never by more than one half-width.
        if (zero > ext && width_at_edge < half_width / 3) ext = std::min(zero, ext + half_width);
      }
    }
  }
  p.push_back(p.back() + ext * dir);
  half_widths.push_back(-1);
}

}  // namespace

Polyline RefineCentreline(const std::vector<cv::Point>& path, const cv::Mat& response, double threshold,
                          double half_width, const CentrelineOptions& opt) {
  Polyline p;
  p.reserve(path.size());
  for (const cv::Point& q : path) p.emplace_back(q.x, q.y);
  if (p.size() < 3) return p;
  const double length = PolylineLength(p);
  const int n = opt.points > 0 ? opt.points : std::max(12, static_cast<int>(length / 2));
  p = ResamplePolyline(p, n);
  const double spacing = length / (n - 1);
  p = SmoothPolyline(p, std::max(1.0, half_width / spacing));
  // Trim the ends: thinning forks at a blunt tip, and the fork bends the path.
  const double trim = std::max(2.0, half_width);
  {
    std::vector<double> s(p.size(), 0.0);
    for (size_t i = 1; i < p.size(); ++i) s[i] = s[i - 1] + (p[i] - p[i - 1]).norm();
    Polyline kept;
    for (size_t i = 0; i < p.size(); ++i)
      if (s[i] >= trim && s[i] <= s.back() - trim) kept.push_back(p[i]);
    if (kept.size() >= 3) p = kept;
  }
  std::vector<double> hw(p.size(), -1.0);
  const double search = 3 * half_width + 3;
  for (int it = 0; it < opt.refine_iterations; ++it) {
    Polyline moved = p;
    for (size_t i = 0; i < p.size(); ++i) {
      const Vec2 nrm = UnitNormal(p, i);
      if (nrm.norm() == 0) continue;
      const double a = DistanceToEdge(response, threshold, p[i], nrm, search);
      const double b = DistanceToEdge(response, threshold, p[i], -nrm, search);
      if (a < 0 || b < 0) continue;
      // Damped: both edges of a touching neighbour section must not pull the point across.
      const double shift = std::clamp(0.5 * (a - b), -half_width, half_width);
      moved[i] = p[i] + shift * nrm;
      hw[i] = 0.5 * (a + b);
    }
    p = SmoothPolyline(moved, 1.0);
  }
  ExtendEnd(p, hw, response, threshold, opt.tip_threshold, half_width, opt.extrapolate_tips);
  std::reverse(p.begin(), p.end());
  std::reverse(hw.begin(), hw.end());
  ExtendEnd(p, hw, response, threshold, opt.tip_threshold, half_width, opt.extrapolate_tips);
  std::reverse(p.begin(), p.end());
  return p;
}

}  // namespace wormdrag::video
