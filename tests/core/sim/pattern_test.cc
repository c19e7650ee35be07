#include "core/sim/pattern.h"

#include <cmath>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

// Without an envelope the pattern is the paper's q_i = A sin(ω t − k i) + B.
TEST(JointPattern, WithoutEnvelopeIsThePapersWave) {
  const JointPattern p = Locomotion(4);
  Shape q, qd;
  p.Evaluate(0.83, &q, &qd);
  for (int i = 1; i <= kNumJoints; ++i) {
    EXPECT_NEAR(q[i - 1], 0.6 * std::sin(5 * 0.83 - 0.6 * i) + 0.1, 1e-14);
    EXPECT_NEAR(qd[i - 1], 0.6 * 5 * std::cos(5 * 0.83 - 0.6 * i), 1e-14);
  }
}

// The rates are the angles' time derivatives, the envelope's included.
TEST(JointPattern, EnvelopeRatesMatchFiniteDifferences) {
  JointPattern p = Locomotion(2);
  p.envelope_depth = 0.6;
  p.envelope_hz = 0.4;
  p.envelope_phase = 1.1;
  const double h = 1e-6;
  for (double t : {0.0, 0.7, 2.9}) {
    Shape q, qd, qp, qm, unused;
    p.Evaluate(t, &q, &qd);
    p.Evaluate(t + h, &qp, &unused);
    p.Evaluate(t - h, &qm, &unused);
    for (int i = 0; i < kNumJoints; ++i) EXPECT_NEAR(qd[i], (qp[i] - qm[i]) / (2 * h), 1e-7) << t << " " << i;
  }
}

// The envelope scales the wave about its offset: A (1 + m) at the crest, A (1 − m) at the
// trough.
TEST(JointPattern, EnvelopeScalesTheWaveAboutItsOffset) {
  JointPattern plain = Locomotion(3), p = plain;
  p.envelope_depth = 0.5;
  p.envelope_hz = 0.25;  // crest at t = 1 s, trough at t = 3 s
  for (auto [t, scale] : {std::pair{1.0, 1.5}, std::pair{3.0, 0.5}, std::pair{2.0, 1.0}}) {
    Shape q, qp, unused;
    p.Evaluate(t, &q, &unused);
    plain.Evaluate(t, &qp, &unused);
    for (int i = 0; i < kNumJoints; ++i) EXPECT_NEAR(q[i] - 0.1, scale * (qp[i] - 0.1), 1e-12) << t << " " << i;
  }
}

}  // namespace
}  // namespace wormdrag
