// Pose integration of a simulated batch (internal to the simulator): RK4 on SE(2)
// from knot to knot, the mid-interval velocity from a cubic through the neighbouring
// knots, poses kept at frames and reset where asked.
#pragma once

#include <vector>

#include "core/sim/pose_step.h"
#include "core/sim/simulator.h"

namespace wormdrag {

// Integrates the lanes of a batch interval by interval as soon as the knots an
// interval's cubic needs are solved, so that a FrameObserver sees every frame while
// the velocities are still being solved. Each lane's arithmetic is that of a lone run.
class PoseIntegrator {
 public:
  // `xi` holds ξ per knot as [knot][3][lane] and must stay valid; `out` gets the poses.
  PoseIntegrator(const ShapeDrive& drive, const PoseResets* resets, const double* xi, int count, Trajectory* out);
  // The lanes 0 … count−1 that go on after the observer (if any) has seen frame 0.
  unsigned Start(int count, FrameObserver* observer);
  // Integrates every interval whose knots are solved (up to `solved`) for the lanes in
  // `live`, reporting each frame reached to the observer; returns the lanes still live.
  unsigned Advance(int solved, unsigned live, FrameObserver* observer);

 private:
  // RK4 over interval j for lane w; the mid-interval ξ from the cubic `mc`.
  void Step(int j, int w, const MidpointCubic& mc);

  const ShapeDrive& drive_;
  const std::vector<KnotGeometry>& knots_;
  const int n_;
  const PoseResets* resets_;
  const double* xi_;
  Trajectory* out_;
  Pose pose_[kLanes];
  int next_ = 0;  // the next interval to integrate
  size_t next_reset_ = 0;
};

}  // namespace wormdrag
