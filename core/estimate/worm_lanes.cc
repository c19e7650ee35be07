// One worm's share of the lane functions, and how the two shares combine (see
// SimulateWormLanes in paired_path.h).
#include <cmath>

#include "core/estimate/paired_path.h"

namespace wormdrag {

void SimulateWormLanes(const PairedPath& pair, int worm, const Coefficients* sets, int count, LaneOutput what,
                       EvaluationWorkspace& ws, WormLanes* out) {
  const ScoredRecording& w = pair.worm(worm);
  if (what == LaneOutput::kJacobians)
    Simulator::SimulateBatchWithSensitivities(w.drive, sets, count, pair.options().sim, &w.resets, ws.sim, ws.traj);
  else
    Simulator::SimulateBatch(w.drive, sets, count, pair.options().sim, &w.resets, ws.sim, ws.traj);
  out->knots = ws.traj[0].summary.knots * count;
  const double scale = 1.0 / std::sqrt(static_cast<double>(pair.scored_count()));
  size_t m = 0;
  for (const auto& f : w.frames) m += 2 * f.model.size();
  for (int i = 0; i < count; ++i) {
    const Trajectory& t = ws.traj[i];
    if (what == LaneOutput::kSums) {
      DistanceSums(w, t, &out->sum[i], &out->sum_sq[i]);
      continue;
    }
    out->residuals[i].clear();
    out->jacobian[i].clear();
    out->failed[i] = !t.summary.ok();
    if (out->failed[i]) continue;
    out->residuals[i].reserve(m);
    std::vector<double>& r = out->residuals[i];
    if (what == LaneOutput::kResiduals) {
      for (const auto& f : w.frames) {
        const Pose& g = t.poses[f.frame_offset];
        const double c = std::cos(g.q0), sn = std::sin(g.q0);
        for (size_t k = 0; k < f.model.size(); ++k) {
          const Vec2& mp = f.model[k];
          r.push_back(scale * (g.x + c * mp.x() - sn * mp.y() - f.measured[k].x()));
          r.push_back(scale * (g.y + sn * mp.x() + c * mp.y() - f.measured[k].y()));
        }
      }
      continue;
    }
    // The residuals as above, term for term, and each point's row of the Jacobian from
    // the pose sensitivities: the point g_xy + R(q0) m̂ has the derivative
    // dg_xy + R'(q0) m̂ dq0.
    std::vector<double>& J = out->jacobian[i];
    J.assign(4 * m, 0.0);
    for (const auto& f : w.frames) {
      const Pose& g = t.poses[f.frame_offset];
      const PoseSensitivity& dg = t.sensitivities[f.frame_offset];
      const double c = std::cos(g.q0), sn = std::sin(g.q0);
      for (size_t k = 0; k < f.model.size(); ++k) {
        const Vec2& mp = f.model[k];
        const double rx = c * mp.x() - sn * mp.y(), ry = sn * mp.x() + c * mp.y();
        const size_t q = r.size();
        for (int a = 0; a < 4; ++a) {
          J[a * m + q] = scale * (dg[0][a] - ry * dg[2][a]);
          J[a * m + q + 1] = scale * (dg[1][a] + rx * dg[2][a]);
        }
        r.push_back(scale * (g.x + c * mp.x() - sn * mp.y() - f.measured[k].x()));
        r.push_back(scale * (g.y + sn * mp.x() + c * mp.y() - f.measured[k].y()));
      }
    }
  }
}

void CombineWormSums(const PairedPath& pair, const std::array<WormLanes, 2>& worms, int count, Objective objective,
                     double* out) {
  const double n = pair.scored_count();
  for (int i = 0; i < count; ++i) {
    // Summed in the order a single accumulator over worm 0, then worm 1, would sum them.
    const double s = objective == Objective::kMeanDistance ? worms[0].sum[i] + worms[1].sum[i]
                                                           : worms[0].sum_sq[i] + worms[1].sum_sq[i];
    out[i] = s / n;
  }
}

void CombineWormResiduals(const std::array<WormLanes, 2>& worms, int count, std::vector<double>* residuals,
                          std::vector<double>* jacobians) {
  for (int i = 0; i < count; ++i) {
    residuals[i].clear();
    if (jacobians) jacobians[i].clear();
    if (worms[0].failed[i] || worms[1].failed[i]) continue;
    const std::vector<double>&r0 = worms[0].residuals[i], &r1 = worms[1].residuals[i];
    residuals[i].reserve(r0.size() + r1.size());
    residuals[i].insert(residuals[i].end(), r0.begin(), r0.end());
    residuals[i].insert(residuals[i].end(), r1.begin(), r1.end());
    if (!jacobians) continue;
    // Column a of the pair's Jacobian: worm 0's rows of column a, then worm 1's.
    const size_t m0 = r0.size(), m1 = r1.size();
    std::vector<double>& J = jacobians[i];
    J.resize(4 * (m0 + m1));
    for (int a = 0; a < 4; ++a) {
      std::copy_n(worms[0].jacobian[i].begin() + a * m0, m0, J.begin() + a * (m0 + m1));
      std::copy_n(worms[1].jacobian[i].begin() + a * m1, m1, J.begin() + a * (m0 + m1) + m0);
    }
  }
}

}  // namespace wormdrag
