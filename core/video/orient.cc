#include "core/video/orient.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace wormdrag::video {
namespace {

// Unit vector along the body toward the head at point k.
Vec2 TowardHead(const Points& p, int k) {
  const int a = std::max(0, k - 1), b = std::min(kNumPoints - 1, k + 1);
  Vec2 d = p[a] - p[b];
  const double n = d.norm();
  return n > 0 ? Vec2(d / n) : Vec2(Vec2::Zero());
}

Points Centred(Points p) {
  Vec2 c = Vec2::Zero();
  for (const Vec2& q : p) c += q;
  c /= kNumPoints;
  for (Vec2& q : p) q -= c;
  return p;
}

// Of two costs of the same comparison in either orientation: +1 when the first is
// clearly better (under half the other and under `limit`), −1 when the second is, else 0.
int ClearChoice(double same, double flip, double limit) {
  const double best = std::min(same, flip), worst = std::max(same, flip);
  if (!(best < 0.5 * worst) || !(best < limit)) return 0;
  return same <= flip ? 1 : -1;
}

// 1. Consecutive valid frames within `max_link_gap` whose orientation is clear form runs.
//    Each frame is turned to match the one before even when that is not clear: a run
//    then starts from the likelier orientation, which its own evidence may still turn.
std::vector<std::vector<int>> LinkFrames(std::vector<FrameTrack>& frames, const OrientOptions& opt) {
  std::vector<std::vector<int>> runs;
  int prev = -1;
  for (int i = 0; i < static_cast<int>(frames.size()); ++i) {
    FrameTrack& f = frames[i];
    if (!f.valid()) continue;
    int choice = 0;
    if (prev >= 0 && i - prev <= opt.max_link_gap + 1) {
      const Points a = opt.positions_comparable ? frames[prev].px : Centred(frames[prev].px);
      const Points b = opt.positions_comparable ? f.px : Centred(f.px);
      // Clear when the better orientation is under half the worse one and the body moved
      // by less than a third of its length.
      const double same = MeanPointDistance(a, b), flip = MeanPointDistanceFlipped(a, b);
      choice = ClearChoice(same, flip, f.length_px / 3);
      if (flip < same) f.px = Reversed(f.px);
    }
    if (choice == 0) runs.emplace_back();
    runs.back().push_back(i);
    prev = i;
  }
  return runs;
}

void Reverse(std::vector<FrameTrack>& frames, const std::vector<int>& run) {
  for (int i : run) frames[i].px = Reversed(frames[i].px);
}

}  // namespace

double SlideCost(const Points& a, const Points& b, double max_slide, double* advance) {
  std::array<double, kNumPoints> s{};
  for (int k = 1; k < kNumPoints; ++k) s[k] = s[k - 1] + (a[k] - a[k - 1]).norm();
  const double la = s.back();
  double lb = 0;
  for (int k = 1; k < kNumPoints; ++k) lb += (b[k] - b[k - 1]).norm();
  if (la <= 0) return std::numeric_limits<double>::infinity();
  // `a` at arc position x from its head (linear between its points).
  auto at = [&](double x) {
    const int k = static_cast<int>(std::upper_bound(s.begin(), s.end(), x) - s.begin()) - 1;
    const int j = std::clamp(k, 0, kNumPoints - 2);
    const double f = (x - s[j]) / std::max(1e-12, s[j + 1] - s[j]);
    return Vec2((1 - f) * a[j] + f * a[j + 1]);
  };
  const double step = std::max(0.5, la / 200);
  double best = std::numeric_limits<double>::infinity();
  for (double d = -max_slide; d <= max_slide + 1e-9; d += step) {
    double sum = 0;
    int n = 0;
    for (int k = 0; k < kNumPoints; ++k) {
      // Advancing by d toward the head: b's point k lies where a's arc is k·lb/13 − d.
      const double x = k * lb / kNumLinks - d;
      if (x < 0 || x > la) continue;
      sum += (b[k] - at(x)).norm();
      ++n;
    }
    if (n >= 5 && sum / n < best) {
      best = sum / n;
      if (advance) *advance = d;
    }
    if (max_slide <= 0) break;
  }
  return best;
}

TravelEvidence Travel(const Points& a, const Points& b) {
  TravelEvidence e;
  for (int k = 0; k < kNumPoints; ++k) {
    const double d = (b[k] - a[k]).dot(TowardHead(a, k));
    e.motion += d;
    e.motion_total += std::abs(d);
  }
  // A wave q(i − c t) travelling toward the tail (c > 0) has ∂q/∂t = −c ∂q/∂i.
  const Shape qa = ShapeOf(a), qb = ShapeOf(b);
  for (int k = 1; k + 1 < kNumJoints; ++k) {
    const double dt = WrapAngle(qb[k] - qa[k]);
    const double di = 0.25 * (WrapAngle(qa[k + 1] - qa[k - 1]) + WrapAngle(qb[k + 1] - qb[k - 1]));
    e.wave -= dt * di;
    e.wave_total += std::abs(dt * di);
  }
  constexpr int kEnd = 3;
  for (int k = 0; k < kEnd; ++k) {
    const double head = std::pow(WrapAngle(qb[k] - qa[k]), 2);
    const double tail = std::pow(WrapAngle(qb[kNumJoints - 1 - k] - qa[kNumJoints - 1 - k]), 2);
    e.swing += head - tail;
    e.swing_total += head + tail;
  }
  return e;
}

TravelEvidence& TravelEvidence::operator+=(const TravelEvidence& o) {
  motion += o.motion;
  motion_total += o.motion_total;
  wave += o.wave;
  wave_total += o.wave_total;
  swing += o.swing;
  swing_total += o.swing_total;
  return *this;
}

TravelEvidence RunTravel(const std::vector<FrameTrack>& frames, const std::vector<int>& run, int lag) {
  TravelEvidence e;
  const size_t l = std::clamp<size_t>(lag, 1, std::max<size_t>(1, run.size() - 1));
  for (size_t j = l; j < run.size(); ++j) e += Travel(frames[run[j - l]].px, frames[run[j]].px);
  return e;
}

void OrderHeadTail(std::vector<FrameTrack>& frames, const OrientOptions& opt, TrackSummary* summary) {
  std::vector<std::vector<int>> runs = LinkFrames(frames, opt);
  // 2. Runs across a short gap join a chain when the later body lies on the earlier one's
  //    track in one orientation only; the later run is turned to match.
  std::vector<int> chain_of(runs.size(), 0);
  int chains = runs.empty() ? 0 : 1;
  for (size_t r = 1; r < runs.size(); ++r) {
    const int last = runs[r - 1].back(), first = runs[r].front();
    int choice = 0;
    if (first - last - 1 <= opt.max_chain_gap) {
      const FrameTrack& a = frames[last];
      const FrameTrack& b = frames[first];
      const Points pa = opt.positions_comparable ? a.px : Centred(a.px);
      const Points pb = opt.positions_comparable ? b.px : Centred(b.px);
      const double slide = opt.positions_comparable ? 0.75 * a.length_px : 0.0;
      choice = ClearChoice(SlideCost(pa, pb, slide), SlideCost(pa, Reversed(pb), slide), a.length_px / 10);
      if (choice < 0) Reverse(frames, runs[r]);
    }
    if (choice == 0) ++chains;
    chain_of[r] = chains - 1;
  }
  // 3. Per chain, over all of its runs: the direction of travel (the body moves toward
  //    its head and the bending wave travels toward its tail; worms crawl forward far
  //    more than backward) and the head's swing. Where positions are comparable, the
  //    travel over a whole chain decides and the swing breaks its ties. In separate crops
  //    only the wave shows the travel, and it turns with every reversal (reversals lead
  //    into the coils that split crops into runs), so there the swing decides and the
  //    wave breaks its ties.
  std::vector<TravelEvidence> evidence(chains);
  for (size_t r = 0; r < runs.size(); ++r) evidence[chain_of[r]] += RunTravel(frames, runs[r], opt.travel_lag);
  // Undecided: under 20 % net evidence.
  auto decided = [](double net) { return std::abs(net) >= 0.2; };
  std::vector<int> sign(chains, 0);
  for (int c = 0; c < chains; ++c) {
    const TravelEvidence& e = evidence[c];
    const double wave = e.WaveNet(), swing = e.SwingNet();
    const double travel = opt.positions_comparable ? 0.5 * (e.MotionNet() + wave) : wave;
    const double first = opt.positions_comparable ? travel : swing;
    const double second = opt.positions_comparable ? swing : travel;
    const double net = decided(first) ? first : second;
    sign[c] = decided(net) ? (net > 0 ? 1 : -1) : 0;
  }
  for (size_t r = 0; r < runs.size(); ++r) {
    for (int i : runs[r]) {
      frames[i].run = static_cast<int>(r);
      frames[i].chain = chain_of[r];
    }
    if (summary) ++summary->runs;
    const int s = sign[chain_of[r]];
    if (s == 0 && summary) ++summary->runs_undecided;
    if (s < 0) {
      Reverse(frames, runs[r]);
      if (summary) ++summary->runs_flipped;
    }
  }
  if (summary) summary->chains = chains;
}

}  // namespace wormdrag::video
