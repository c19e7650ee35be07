// What happens to a CeleST worm's frames after reading (internal/celest_frames.h):
// CeleST's flags and length checks, glitches, and the head/tail order of each run.
#include "core/io/internal/celest_frames.h"

#include <algorithm>
#include <cmath>

namespace wormdrag::celest_internal {
namespace {

// Shape distance regardless of head/tail order.
double BestDistance(const Points& a, const Points& b) {
  return std::min(MeanPointDistance(a, b), MeanPointDistanceFlipped(a, b));
}

Vec2 Centroid(const Points& p) {
  Vec2 c = Vec2::Zero();
  for (const Vec2& q : p) c += q;
  return c / kNumPoints;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

std::vector<int> ValidIndices(const std::vector<Candidate>& c) {
  std::vector<int> v;
  for (int i = 0; i < static_cast<int>(c.size()); ++i)
    if (c[i].reason == Reason::kValid) v.push_back(i);
  return v;
}

double MedianLength(const std::vector<Candidate>& c) {
  std::vector<double> l;
  for (int i : ValidIndices(c)) l.push_back(c[i].length_px);
  return Median(l);
}

}  // namespace

std::vector<Candidate> Classify(const std::vector<RawFrame>& raw, const CelestOptions& opt) {
  std::vector<Candidate> out(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    const RawFrame& r = raw[i];
    Candidate& c = out[i];
    c.reason = r.lost         ? Reason::kLost
               : r.missed     ? Reason::kMissed
               : r.overlapped ? Reason::kOverlapped
                              : Reason::kNoCentreline;
    if (c.reason != Reason::kNoCentreline || !r.present || static_cast<int>(r.px.size()) < opt.min_points) continue;
    auto p = ResampleByArcLength(r.px);
    if (!p.ok()) continue;  // all points coincide
    c.p = *p;
    c.length_px = ArcLength(r.px);
    c.reason = Reason::kValid;
  }
  const double median = MedianLength(out);
  for (Candidate& c : out)
    if (c.reason == Reason::kValid && std::abs(c.length_px / median - 1) > opt.max_length_deviation)
      c.reason = Reason::kLength;
  return out;
}

void DropGlitches(std::vector<Candidate>& c, const CelestOptions& opt) {
  const std::vector<int> v = ValidIndices(c);
  const int n = static_cast<int>(v.size());
  if (n < 3) return;
  std::vector<double> d(n, 0.0);  // d[j]: from v[j-1] to v[j]
  for (int j = 1; j < n; ++j) d[j] = BestDistance(c[v[j - 1]].p, c[v[j]].p);
  const double limit = std::max(opt.glitch_factor * Median(std::vector<double>(d.begin() + 1, d.end())),
                                opt.glitch_floor * MedianLength(c));
  auto near = [&](int j0, int j1) { return v[j1] - v[j0] <= opt.max_link_gap + 1; };
  std::vector<int> drop;
  for (int j = 0; j < n; ++j) {
    bool glitch = false;
    if (j == 0) {
      glitch = near(0, 1) && near(1, 2) && d[1] > limit && d[2] <= limit;
    } else if (j == n - 1) {
      glitch = near(n - 2, n - 1) && near(n - 3, n - 2) && d[n - 1] > limit && d[n - 2] <= limit;
    } else if (near(j - 1, j) && near(j, j + 1)) {
      glitch = d[j] > limit && d[j + 1] > limit && BestDistance(c[v[j - 1]].p, c[v[j + 1]].p) <= limit;
    }
    if (glitch) drop.push_back(v[j]);
  }
  for (int i : drop) c[i].reason = Reason::kGlitch;
}

void OrderHeadTail(std::vector<Candidate>& c, const CelestOptions& opt, CelestSummary* s) {
  std::vector<std::vector<int>> runs;
  int prev = -1;
  for (int i : ValidIndices(c)) {
    bool linked = false;
    if (prev >= 0 && i - prev <= opt.max_link_gap + 1) {
      const double same = MeanPointDistance(c[prev].p, c[i].p), flip = MeanPointDistanceFlipped(c[prev].p, c[i].p);
      const double best = std::min(same, flip), worst = std::max(same, flip);
      linked = best < 0.5 * worst && best < c[i].length_px / 3;
      if (linked) {
        s->swaps_fixed += flip < same;
        c[i].reversed = c[prev].reversed != (flip < same);
      }
    }
    if (!linked) runs.emplace_back();
    runs.back().push_back(i);
    prev = i;
  }
  const double body = MedianLength(c);
  for (const std::vector<int>& run : runs) {
    double along = 0;  // net centroid displacement toward the head, pixels
    for (size_t j = 1; j < run.size(); ++j) {
      const Candidate& a = c[run[j - 1]];
      const Points pa = a.reversed ? Reversed(a.p) : a.p;
      const Points pb = c[run[j]].reversed ? Reversed(c[run[j]].p) : c[run[j]].p;
      const Vec2 axis = pa.front() - pa.back();  // tail → head
      if (axis.norm() > 0) along += (Centroid(pb) - Centroid(pa)).dot(axis / axis.norm());
    }
    ++s->runs;
    const double travel = along / body;
    if (std::abs(travel) < opt.min_travel) {
      ++s->runs_undecided;
      s->travel += travel;
      continue;
    }
    s->travel += std::abs(travel);
    if (travel < 0) {
      ++s->runs_flipped;
      for (int i : run) c[i].reversed = !c[i].reversed;
    }
  }
}

}  // namespace wormdrag::celest_internal
