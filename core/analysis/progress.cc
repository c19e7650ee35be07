#include "core/analysis/progress.h"

#include <algorithm>
#include <cmath>

#include "core/common/stats.h"

namespace wormdrag {
namespace {

// Scored frames [begin, end) of one stretch of one worm.
struct Span {
  size_t begin, end;
};

std::vector<Span> Stretches(const ScoredRecording& w) {
  std::vector<Span> out;
  const auto& resets = w.resets.frames;
  size_t begin = 0;
  for (size_t i = 1; i <= w.frames.size(); ++i) {
    const bool ends = i == w.frames.size() || std::binary_search(resets.begin(), resets.end(),
                                                                 w.drive.first_frame() + w.frames[i].frame_offset);
    if (!ends) continue;
    if (i - begin >= 3) out.push_back({begin, i});
    begin = i;
  }
  return out;
}

Vec2 Centroid(const std::vector<Vec2>& p) {
  Vec2 c = Vec2::Zero();
  for (const Vec2& v : p) c += v;
  return c / static_cast<double>(p.size());
}

}  // namespace

Result<ProgressComparison> CompareProgress(const PairedPath& pair, const std::vector<Coefficients>& sets) {
  if (sets.empty()) return Status::InvalidArgument("no coefficient set to simulate");
  const std::vector<int>& points = pair.options().points;
  if (points.size() < 2) return Status::InvalidArgument("progress needs at least two evaluation points (a body axis)");
  // The axis runs from the point nearest the tail to the one nearest the head.
  const auto [lo, hi] = std::minmax_element(points.begin(), points.end());
  const size_t head = lo - points.begin(), tail = hi - points.begin();
  std::vector<PathComparison> paths;
  for (const Coefficients& c : sets) {
    auto cmp = ComparePaths(pair, c);
    if (!cmp.ok()) return cmp.status();
    paths.push_back(std::move(*cmp));
  }
  ProgressComparison out;
  out.sets = sets;
  for (int j = 0; j < 2; ++j) {
    const auto& measured = paths[0].measured[j];
    const auto& t = paths[0].t[j];
    for (const Span& s : Stretches(pair.worm(j))) {
      Vec2 axis = Vec2::Zero();
      for (size_t f = s.begin; f < s.end; ++f) axis += measured[f][head] - measured[f][tail];
      if (!(axis.norm() > 0)) continue;
      axis.normalize();
      const Vec2 side(-axis.y(), axis.x());
      StretchProgress p;
      p.worm = j;
      p.t0 = t[s.begin];
      p.t1 = t[s.end - 1];
      const double dt = p.t1 - p.t0;
      const Vec2 v = (Centroid(measured[s.end - 1]) - Centroid(measured[s.begin])) / dt;
      p.measured_along = v.dot(axis);
      p.measured_side = v.dot(side);
      for (const PathComparison& path : paths) {
        const auto& sim = path.simulated[j];
        const Vec2 u = (Centroid(sim[s.end - 1]) - Centroid(sim[s.begin])) / dt;
        p.along.push_back(u.dot(axis));
        p.side.push_back(u.dot(side));
      }
      out.stretches.push_back(std::move(p));
    }
  }
  return out;
}

ProgressMean MeanOverStretches(const std::vector<double>& per_stretch) {
  const SampleSummary s = Summarize(per_stretch);
  ProgressMean m;
  m.n = s.n;
  m.mean = s.mean;
  m.se = s.n > 1 ? s.sd / std::sqrt(static_cast<double>(s.n)) : NAN;
  m.p_zero = m.se > 0 ? 2 * (1 - StudentTCdf(std::abs(m.mean) / m.se, s.n - 1)) : NAN;
  return m;
}

}  // namespace wormdrag
