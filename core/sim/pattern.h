// The paper's travelling-wave joint-angle pattern q_i(t) = A sin(ω t − k i) + B
// (i = 1 … N−1) and synthetic recordings made by simulating it.
#pragma once

#include "core/common/status.h"
#include "core/io/kinematics.h"
#include "core/sim/simulator.h"

namespace wormdrag {

struct JointPattern {
  double amplitude = 0.4;   // A, rad
  double offset = 0.0;      // B, rad
  double omega = 5.0;       // ω, rad/s
  double wavenumber = 0.6;  // k, rad per joint
  void Evaluate(double t, Shape* q, Shape* qdot) const;
};

// The verification patterns Locomotion 1–4 of the paper (docs/conventions.md §3), index 1…4.
JointPattern Locomotion(int index);

struct RecordingSpec {
  double fps = 300;
  double duration = 5;  // s; frames at 0, 1/fps, …, duration
  BodyModel body;       // length 1 mm by default
  Pose initial;         // head at the origin, link 1 along +x
  int substeps = 4;     // finer than estimation, so the truth is accurate
  // false: the joint angles are the analytic pattern between frames (a model of a
  // real animal). true: they are the spline through the sampled frames, exactly as
  // the estimator rebuilds them, so estimating with the same solver settings
  // reproduces the data (the paper's verification: one simulator for both).
  bool as_estimated = false;
};

// Simulates the pattern with the given coefficients and writes every frame's 14 points.
Result<Kinematics> GenerateRecording(const JointPattern& pattern, const Coefficients& c, const SimOptions& sim,
                                     const RecordingSpec& spec);

}  // namespace wormdrag
