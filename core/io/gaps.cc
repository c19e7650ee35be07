#include "core/io/gaps.h"

#include <cmath>

namespace wormdrag {

int InterpolateShortGaps(Kinematics& k, int max_gap_frames) {
  if (max_gap_frames <= 0) return 0;
  const int n = static_cast<int>(k.frames.size());
  int filled = 0;
  int prev = -1;
  for (int i = 0; i < n; ++i) {
    if (!k.frames[i].valid) continue;
    const int gap = prev >= 0 ? i - prev - 1 : 0;
    if (gap > 0 && gap <= max_gap_frames) {
      const Frame& a = k.frames[prev];
      const Frame& b = k.frames[i];
      const Shape qa = ShapeOf(a.p), qb = ShapeOf(b.p);
      const double la = MeanLinkLength(a.p), lb = MeanLinkLength(b.p);
      const Pose ga = BestFitPose(a.p, qa, la), gb = BestFitPose(b.p, qb, lb);
      const double dq0 = WrapAngle(gb.q0 - ga.q0);
      for (int j = prev + 1; j < i; ++j) {
        const double u = static_cast<double>(j - prev) / (i - prev);
        Shape q;
        for (int m = 0; m < kNumJoints; ++m) q[m] = qa[m] + u * WrapAngle(qb[m] - qa[m]);
        Pose g;
        g.x = ga.x + u * (gb.x - ga.x);
        g.y = ga.y + u * (gb.y - ga.y);
        g.q0 = ga.q0 + u * dq0;
        const double l = la + u * (lb - la);
        Frame& f = k.frames[j];
        f.p = LabPoints(g, q, l);
        f.valid = true;
        f.arc_length = a.arc_length + u * (b.arc_length - a.arc_length);
        ++filled;
      }
    }
    prev = i;
  }
  if (filled > 0) k.metadata["interpolated_frames"] = std::to_string(filled);
  return filled;
}

}  // namespace wormdrag
