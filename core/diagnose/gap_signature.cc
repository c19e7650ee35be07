#include "core/diagnose/gap_signature.h"

#include <algorithm>
#include <cmath>

#include "core/diagnose/diagnosis.h"

namespace wormdrag::diagnose {
namespace {

struct Ratio {
  double value = 0, var = 0;
};

// Σ x_i / Σ w_i with x_i = Δr·Δc, w_i = |Δc|², and its delta-method variance
// Σ (x_i − R w_i)² / (Σ w_i)².
Ratio RatioOf(const std::vector<GapWindow>& ws) {
  double sx = 0, sw = 0;
  for (const auto& w : ws) {
    sx += w.residual_change.dot(w.model_displacement);
    sw += w.model_displacement.squaredNorm();
  }
  Ratio r;
  if (!(sw > 0)) return r;
  r.value = sx / sw;
  double se2 = 0;
  for (const auto& w : ws) {
    const double e = w.residual_change.dot(w.model_displacement) - r.value * w.model_displacement.squaredNorm();
    se2 += e * e;
  }
  const double n = static_cast<double>(ws.size());
  r.var = n > 1 ? se2 / (sw * sw) * n / (n - 1) : 0.0;
  return r;
}

}  // namespace

GapSignature SummariseGapWindows(const std::vector<GapWindow>& at_gaps, const std::vector<GapWindow>& elsewhere) {
  GapSignature s;
  s.gaps = static_cast<int>(at_gaps.size());
  s.windows = static_cast<int>(elsewhere.size());
  const Ratio g = RatioOf(at_gaps), e = RatioOf(elsewhere);
  s.at_gaps = g.value;
  s.elsewhere = e.value;
  s.excess = g.value - e.value;
  s.se = std::sqrt(g.var + e.var);
  return s;
}

void AddGapWindows(const EffectRecording& w, const EffectTrajectory& tr, std::vector<GapWindow>* at_gaps,
                   std::vector<GapWindow>* elsewhere) {
  const ShapeDrive& sd = w.drive->drive();
  const auto& fr = w.kinematics.frames;
  const int first = sd.first_frame(), last = sd.last_frame();
  // Per valid frame: the simulated centroid and the translation residual.
  std::vector<Vec2> model(last - first + 1, Vec2::Zero()), resid(last - first + 1, Vec2::Zero());
  std::vector<char> valid(last - first + 1, 0);
  for (int f = first; f <= last; ++f) {
    if (!fr[f].valid) continue;
    const Points S = EffectPoints(*w.drive, tr, f);
    Vec2 cs = Vec2::Zero(), cp = Vec2::Zero();
    for (int k = 0; k < kNumPoints; ++k) {
      cs += S[k] / kNumPoints;
      cp += fr[f].p[k] / kNumPoints;
    }
    model[f - first] = cs;
    resid[f - first] = cp - cs;
    valid[f - first] = 1;
  }
  auto window = [&](int a, int b) {
    return GapWindow{resid[b - first] - resid[a - first], model[b - first] - model[a - first]};
  };
  // The runs: from the valid frame before to the valid frame after. Their length in
  // frames (of this recording, possibly subsampled) sets the other windows' length.
  std::vector<char> near_gap(last - first + 1, 0);
  std::vector<int> lengths;
  for (const auto& [g0, g1] : w.drive->gaps()) {
    const int a = g0 - 1, b = g1 + 1;
    if (a < first || b > last || !valid[a - first] || !valid[b - first]) continue;
    at_gaps->push_back(window(a, b));
    lengths.push_back(b - a);
    for (int f = a; f <= b; ++f) near_gap[f - first] = 1;
  }
  if (lengths.empty()) return;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  const int m = lengths[lengths.size() / 2];
  // Non-overlapping windows of m frames over valid frames that touch no run.
  for (int a = first; a + m <= last;) {
    bool clean = true;
    for (int f = a; f <= a + m && clean; ++f) clean = valid[f - first] && !near_gap[f - first];
    if (!clean) {
      ++a;
      continue;
    }
    elsewhere->push_back(window(a, a + m));
    a += m;
  }
}

GapSignature MeasureGapSignature(const EffectData& d, const Coefficients& c, double eps) {
  std::vector<GapWindow> at_gaps, elsewhere;
  for (const auto& w : d.worms) {
    if (!w.drive) continue;
    EffectSimOptions so;
    so.epsilon = eps;
    const EffectTrajectory tr = SimulateEffects(*w.drive, c, {}, so);
    if (tr.ok()) AddGapWindows(w, tr, &at_gaps, &elsewhere);
  }
  return SummariseGapWindows(at_gaps, elsewhere);
}

}  // namespace wormdrag::diagnose
