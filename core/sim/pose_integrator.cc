#include "core/sim/internal/pose_integrator.h"

#include "core/sim/internal/kernel.h"

namespace wormdrag {
namespace {

using sim_kernel::W;

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
  while (next_ + 1 < n_ && live != 0) {
    const MidpointCubic mc = MidpointCubicAt(knots_, next_);
    if (mc.last() > solved) break;
    const int j = next_++;
    for (int w = 0; w < W; ++w)
      if ((live >> w) & 1u) Step(j, w, mc);
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

void PoseIntegrator::Step(int j, int w, const MidpointCubic& mc) {
  auto xi = [&](int k, int r) { return xi_[(static_cast<size_t>(k) * 3 + r) * W + w]; };
  const double x0[3] = {xi(j, 0), xi(j, 1), xi(j, 2)};
  const double x1[3] = {xi(j + 1, 0), xi(j + 1, 1), xi(j + 1, 2)};
  double xm[3];
  MidpointXi(mc, xi, xm);
  PoseRk4Step(knots_[j + 1].t - knots_[j].t, x0, xm, x1, nullptr, &pose_[w]);
}

}  // namespace wormdrag
