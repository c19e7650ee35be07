// The paper's travelling-wave joint-angle pattern q_i(t) = A sin(ω t − k i) + B
// (i = 1 … N−1), optionally with an amplitude envelope A(t) = A (1 + m sin(2π f_e t + φ))
// (a gait that strengthens and weakens, as real worms' do), and synthetic recordings
// made by simulating it.
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
  // The envelope: depth m (0 = none, the paper's constant amplitude; < 1 keeps A(t) > 0),
  // frequency f_e in Hz and phase φ in rad.
  double envelope_depth = 0.0;
  double envelope_hz = 0.0;
  double envelope_phase = 0.0;
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
