// Synthetic recordings with known effects (docs/conventions.md §5): the body is driven by a joint-
// angle pattern or by the joint angles of a recording (e.g. a real kymogram), simulated
// with the effect-aware solver, given gaps and tracking noise, seeded. The truth (what
// was injected) is written separately, so a diagnosis can be scored against it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/effect_sim.h"
#include "core/diagnose/effects.h"
#include "core/io/kinematics.h"
#include "core/sim/pattern.h"

namespace wormdrag::diagnose {

// Runs of missing frames: `length` frames dropped every `every` frames, the first run
// starting at frame `first` (0 = none). WT2 drops 5–8 frames every 12–25.
struct GapPattern {
  int every = 0;
  int length = 0;
  int first = 10;
  std::vector<std::pair<int, int>> Runs(int frames) const;  // [first, last], each with a frame on both sides
};

struct SynthSpec {
  // Shape source: the pattern unless `shapes` is set (joint angles of its valid frames,
  // spline-interpolated, starting `shapes_offset` s after its first frame).
  JointPattern pattern = Locomotion(1);
  const Kinematics* shapes = nullptr;
  double shapes_offset = 0;
  double fps = 300;     // output frame rate
  double duration = 5;  // s
  BodyModel body;       // length 1 mm by default
  Pose initial;         // first pose
  Coefficients coef{0.5, 0.2, 0.005, 0.002};
  EffectParams effects;
  double noise = 0;  // tracking noise: σ of each point coordinate, mm
  uint64_t seed = 1;
  GapPattern gaps;
  int substeps = 4;  // solver knots per frame (finer than a fit's)
  double epsilon = kDefaultEpsilon;
  Status Validate() const;
};

struct SynthOutput {
  Kinematics recording;  // with noise and gaps: what a tracker would deliver
  Kinematics clean;      // the exact simulated points, every frame
  Json truth;            // what generated it: coefficients, effects, noise, seed, gaps, source
};

Result<SynthOutput> Synthesize(const SynthSpec& spec);

// The joint angles of a recording as a function of time (not-a-knot splines through
// the valid frames, unwrapped), and its first/last valid times.
Result<ShapeDrive::ShapeFunction> RecordingShape(const Kinematics& k, double* t_first, double* t_last);

// Adds Gaussian noise of σ mm to every coordinate of every valid frame (seeded).
void AddTrackingNoise(Kinematics* k, double sigma, uint64_t seed);

}  // namespace wormdrag::diagnose
