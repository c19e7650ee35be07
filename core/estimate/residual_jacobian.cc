// The residuals' Jacobian from the simulator's forward sensitivities (see
// ResidualJacobianLanes in paired_path.h).
#include <cmath>

#include "core/estimate/paired_path.h"

namespace wormdrag {

// The residuals are computed as by ResidualLanes, term for term, so they are the same
// bits; each point's row of the Jacobian follows from the pose sensitivities.
void ResidualJacobianLanes(const PairedPath& pair, const Coefficients* sets, int count, EvaluationWorkspace& ws,
                           std::vector<double>* residuals, std::vector<double>* jacobian) {
  const double scale = 1.0 / std::sqrt(static_cast<double>(pair.scored_count()));
  const size_t m = 2 * static_cast<size_t>(pair.scored_count());
  bool failed[kLanes] = {};
  for (int i = 0; i < count; ++i) {
    residuals[i].clear();
    jacobian[i].assign(4 * m, 0.0);
  }
  for (int j = 0; j < 2; ++j) {
    const ScoredRecording& w = pair.worm(j);
    Simulator::SimulateBatchWithSensitivities(w.drive, sets, count, pair.options().sim, &w.resets, ws.sim, ws.traj);
    for (int i = 0; i < count; ++i) {
      if (!ws.traj[i].summary.ok()) failed[i] = true;
      if (failed[i]) continue;
      for (const auto& f : w.frames) {
        const Pose& g = ws.traj[i].poses[f.frame_offset];
        const PoseSensitivity& dg = ws.traj[i].sensitivities[f.frame_offset];
        const double c = std::cos(g.q0), sn = std::sin(g.q0);
        for (size_t k = 0; k < f.model.size(); ++k) {
          const Vec2& mp = f.model[k];
          // The point is g_xy + R(q0) m̂: its derivative is dg_xy + R'(q0) m̂ dq0.
          const double rx = c * mp.x() - sn * mp.y(), ry = sn * mp.x() + c * mp.y();
          const size_t q = residuals[i].size();
          for (int a = 0; a < 4; ++a) {
            jacobian[i][a * m + q] = scale * (dg[0][a] - ry * dg[2][a]);
            jacobian[i][a * m + q + 1] = scale * (dg[1][a] + rx * dg[2][a]);
          }
          residuals[i].push_back(scale * (g.x + c * mp.x() - sn * mp.y() - f.measured[k].x()));
          residuals[i].push_back(scale * (g.y + sn * mp.x() + c * mp.y() - f.measured[k].y()));
        }
      }
    }
  }
  for (int i = 0; i < count; ++i)
    if (failed[i]) {
      residuals[i].clear();
      jacobian[i].clear();
    }
}

}  // namespace wormdrag
