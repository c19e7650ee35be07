#include "core/sim/internal/pose_integrator.h"

#include <algorithm>
#include <cmath>

#include "core/sim/internal/kernel.h"

namespace wormdrag {
namespace {

using sim_kernel::PoseRate;
using sim_kernel::W;

inline double MidValue(const double* weight, int lo, int m, const double* xi_series, int comp, int lane) {
  double sum = 0;
  for (int a = 0; a < m; ++a) sum += weight[a] * xi_series[(static_cast<size_t>(lo + a) * 3 + comp) * W + lane];
  return sum;
}

}  // namespace

PoseIntegrator::PoseIntegrator(const ShapeDrive& drive, const PoseResets* resets, const double* xi, int count,
                               Trajectory* out)
    : drive_(drive), knots_(drive.knots()), n_(static_cast<int>(knots_.size())), resets_(resets), xi_(xi), out_(out) {
  for (int w = 0; w < count; ++w) {
    out[w].first_frame = drive.first_frame();
    out[w].poses.resize(drive.num_frames());
    out[w].poses[0] = pose_[w] = drive.initial_pose();
  }
}

unsigned PoseIntegrator::Start(int count, FrameObserver* observer) {
  const unsigned all = (1u << count) - 1u;
  return observer ? observer->Frame(0, all) & all : all;
}

unsigned PoseIntegrator::Advance(int solved, unsigned live, FrameObserver* observer) {
  const int S = drive_.substeps();
  while (next_ + 1 < n_ && LastKnotNeeded(next_) <= solved && live != 0) {
    const int j = next_++;
    int lo, m;
    double weight[4];
    sim_kernel::MidWeights(knots_, n_, j, &lo, &m, weight);
    for (int w = 0; w < W; ++w)
      if ((live >> w) & 1u) Step(j, w, lo, weight);
    if ((j + 1) % S != 0) continue;
    const int fi = (j + 1) / S;  // frame offset from first_frame
    const int frame = drive_.first_frame() + fi;
    if (resets_) {
      while (next_reset_ < resets_->frames.size() && resets_->frames[next_reset_] < frame) ++next_reset_;
      if (next_reset_ < resets_->frames.size() && resets_->frames[next_reset_] == frame)
        for (int w = 0; w < W; ++w)
          if ((live >> w) & 1u) pose_[w] = drive_.MeasuredPose(frame);
    }
    for (int w = 0; w < W; ++w)
      if ((live >> w) & 1u) out_[w].poses[fi] = pose_[w];
    if (observer) live = observer->Frame(fi, live) & live;
  }
  return live;
}

int PoseIntegrator::LastKnotNeeded(int j) const {
  const int m = std::min(n_, 4);
  return std::clamp(j - 1, 0, n_ - m) + m - 1;
}

void PoseIntegrator::Step(int j, int w, int lo, const double* weight) {
  Pose& p = pose_[w];
  const double h = knots_[j + 1].t - knots_[j].t;
  const int m = std::min(n_, 4);
  const double x0[3] = {xi_[(j * 3 + 0) * W + w], xi_[(j * 3 + 1) * W + w], xi_[(j * 3 + 2) * W + w]};
  const double xm[3] = {MidValue(weight, lo, m, xi_, 0, w), MidValue(weight, lo, m, xi_, 1, w),
                        MidValue(weight, lo, m, xi_, 2, w)};
  const double x1[3] = {xi_[((j + 1) * 3 + 0) * W + w], xi_[((j + 1) * 3 + 1) * W + w], xi_[((j + 1) * 3 + 2) * W + w]};
  double k1[3], k2[3], k3[3], k4[3];
  PoseRate(p, x0, k1);
  PoseRate({p.x + 0.5 * h * k1[0], p.y + 0.5 * h * k1[1], p.q0 + 0.5 * h * k1[2]}, xm, k2);
  PoseRate({p.x + 0.5 * h * k2[0], p.y + 0.5 * h * k2[1], p.q0 + 0.5 * h * k2[2]}, xm, k3);
  PoseRate({p.x + h * k3[0], p.y + h * k3[1], p.q0 + h * k3[2]}, x1, k4);
  p.x += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
  p.y += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
  p.q0 += h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]);
}

}  // namespace wormdrag
