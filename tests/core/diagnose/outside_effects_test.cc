// The out-of-catalogue `boundary` effect (core/diagnose/effects.h): its definition, its
// pose-dependent simulation against the standard one, its convergence, and its first-order
// response where friction is viscous.
#include <cmath>

#include <gtest/gtest.h>

#include "core/diagnose/effect_sim.h"
#include "core/diagnose/effects.h"
#include "tests/core/diagnose/testing.h"

namespace wormdrag::diagnose {
namespace {

using test::MaxPoseDistance;

const Coefficients kCoulomb{0.62, 0.21, 0.0071, 0.0013};
const Coefficients kViscous{1e-6, 1e-6, 0.0071, 0.0013};

// A travelling wave on a 1 mm body, 100 fps for 2 s, `substeps` knots per frame.
EffectDrive Wave(int substeps = 2) {
  std::vector<double> t;
  for (int i = 0; i <= 200; ++i) t.push_back(i / 100.0);
  BodyModel body;
  body.length = 1.0;
  auto d = EffectDrive::FromFunction(
      t,
      [](double time, Shape* q, Shape* qd) {
        for (int i = 0; i < kNumJoints; ++i) {
          const double ph = 2 * M_PI * (time - (i + 1) / 12.0);
          (*q)[i] = 0.5 * std::sin(ph);
          (*qd)[i] = 0.5 * 2 * M_PI * std::cos(ph);
        }
      },
      body, Pose{}, substeps);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return *d;
}

EffectParams Boundary(double a) {
  EffectParams p;
  p.boundary = a;
  return p;
}

TEST(Boundary, IsOutOfTheCatalogueAndParses) {
  EXPECT_FALSE(InfoOf(Effect::kBoundary).in_catalogue);
  auto p = ParseEffects({"boundary=1.5"});
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p->boundary, 1.5);
  EXPECT_TRUE(p->Has(Effect::kBoundary));
  EXPECT_EQ(p->ToString(), "boundary=1.5");
  EXPECT_FALSE(ParseEffects({"boundary=-1"}).ok());  // friction would vanish beyond the line
}

// A boundary too weak to matter takes the pose-dependent (Heun) path; it agrees with the
// standard path (RK4 on the knot velocities) to the integrators' accuracy, far below
// tracking noise.
TEST(Boundary, PoseDependentPathAgreesWithTheStandardOneWhenNegligible) {
  const EffectDrive d = Wave();
  const EffectTrajectory base = SimulateEffects(d, kCoulomb, {}, {}),
                         heun = SimulateEffects(d, kCoulomb, Boundary(1e-12), {});
  ASSERT_TRUE(base.ok() && heun.ok());
  EXPECT_LT(MaxPoseDistance(d, base, heun), 3e-4);
}

// With Coulomb friction the body's velocity sits where links stop sliding sideways, and a
// moderate change of the weights leaves it there; a tail tip that gets ten times the
// friction beyond the line catches on it and turns the body. That path is physics, not the
// integrator's: it converges as the knots refine.
TEST(Boundary, StrongCoulombBoundaryCatchesTheBodyAndConverges) {
  double previous = NAN, last_step = NAN;
  for (int substeps : {2, 4, 8, 16}) {
    const EffectDrive d = Wave(substeps);
    const EffectTrajectory base = SimulateEffects(d, kCoulomb, {}, {}),
                           b = SimulateEffects(d, kCoulomb, Boundary(9), {});
    ASSERT_TRUE(base.ok() && b.ok());
    const Points pb = EffectPoints(d, b, d.drive().last_frame()), pa = EffectPoints(d, base, d.drive().last_frame());
    const double moved = (pb[0] - pa[0]).norm();
    EXPECT_GT(moved, 0.1) << substeps;  // 100 µm: fifty times the tracking noise
    if (std::isfinite(previous)) last_step = std::abs(moved - previous);
    previous = moved;
  }
  EXPECT_LT(last_step, 1e-3);
}

// Where friction is viscous the balance is linear in the coefficients, and so the path's
// change is, to first order, linear in A.
TEST(Boundary, ViscousResponseIsLinearInTheStep) {
  const EffectDrive d = Wave();
  const EffectTrajectory base = SimulateEffects(d, kViscous, {}, {});
  const EffectTrajectory one = SimulateEffects(d, kViscous, Boundary(0.01), {}),
                         two = SimulateEffects(d, kViscous, Boundary(0.02), {});
  ASSERT_TRUE(base.ok() && one.ok() && two.ok());
  const double d1 = MaxPoseDistance(d, base, one), d2 = MaxPoseDistance(d, base, two);
  EXPECT_GT(d1, 1e-5);
  EXPECT_NEAR(d2 / d1, 2.0, 0.1);
}

}  // namespace
}  // namespace wormdrag::diagnose
