#include "core/sim/pattern.h"

#include <cmath>
#include <cstdio>

namespace wormdrag {

void JointPattern::Evaluate(double t, Shape* q, Shape* qdot) const {
  // Without an envelope no envelope arithmetic enters, so the paper's wave is its closed
  // form bit for bit.
  double a = amplitude, ad = 0;
  if (envelope_depth != 0) {
    const double we = 2 * M_PI * envelope_hz, pe = we * t + envelope_phase;
    a = amplitude * (1 + envelope_depth * std::sin(pe));
    ad = amplitude * envelope_depth * we * std::cos(pe);
  }
  for (int i = 1; i <= kNumJoints; ++i) {
    const double ph = omega * t - wavenumber * i;
    (*q)[i - 1] = a * std::sin(ph) + offset;
    (*qdot)[i - 1] = envelope_depth != 0 ? a * omega * std::cos(ph) + ad * std::sin(ph) : a * omega * std::cos(ph);
  }
}

JointPattern Locomotion(int index) {
  static const double kAB[4][2] = {{0.4, 0.0}, {0.6, 0.0}, {0.4, 0.1}, {0.6, 0.1}};
  JointPattern p;
  p.amplitude = kAB[(index - 1) & 3][0];
  p.offset = kAB[(index - 1) & 3][1];
  return p;
}

Result<Kinematics> GenerateRecording(const JointPattern& pattern, const Coefficients& c, const SimOptions& sim,
                                     const RecordingSpec& spec) {
  if (!(spec.fps > 0)) return Status::InvalidArgument("fps must be positive");
  if (!(spec.duration > 0)) return Status::InvalidArgument("duration must be positive");
  WORMDRAG_RETURN_IF_ERROR(sim.Validate());
  const long n = std::lround(spec.duration * spec.fps) + 1;
  if (n > 10'000'000)
    return Status::ResourceExhausted("duration × fps is too large (" + std::to_string(n) + " frames)");
  std::vector<double> times(n);
  for (long f = 0; f < n; ++f) times[f] = f / spec.fps;
  ShapeDriveOptions dopt;
  dopt.substeps = spec.substeps;
  auto analytic = ShapeDrive::FromFunction(
      times, [&](double t, Shape* q, Shape* qd) { pattern.Evaluate(t, q, qd); }, spec.body, spec.initial, dopt);
  if (!analytic.ok()) return analytic.status();
  Result<ShapeDrive> drive = std::move(analytic);
  if (spec.as_estimated) {
    Kinematics shapes;
    shapes.fps = spec.fps;
    shapes.frames.resize(n);
    for (long f = 0; f < n; ++f) {
      shapes.frames[f].t = times[f];
      shapes.frames[f].valid = true;
      shapes.frames[f].p = LabPoints(spec.initial, drive->FrameShape(static_cast<int>(f)), spec.body.link_length());
      shapes.frames[f].arc_length = spec.body.length;
    }
    drive = ShapeDrive::Build(shapes, spec.body, dopt);
    if (!drive.ok()) return drive.status();
  }
  Trajectory traj = Simulator::Simulate(*drive, c, sim);
  if (!traj.summary.singular.empty())
    return Status::FailedPrecondition("coefficients " + c.ToString() + " are singular for the " +
                                      SolverName(sim.solver) + " solver: " + traj.summary.singular);
  if (traj.summary.unconverged > 0)
    return Status::Internal("the velocity solver did not converge at " + std::to_string(traj.summary.unconverged) +
                            " knots");
  Kinematics k;
  k.fps = spec.fps;
  char buf[200];
  std::snprintf(buf, sizeof buf, "q_i(t) = %g sin(%g t - %g i) + %g", pattern.amplitude, pattern.omega,
                pattern.wavenumber, pattern.offset);
  k.metadata["source"] = std::string("wormdrag generate: ") + buf;
  k.metadata["coefficients"] = c.ToString();
  k.metadata["solver"] = SolverName(sim.solver);
  k.metadata["generation"] = std::string(spec.as_estimated ? "spline through frames" : "analytic") + ", substeps " +
                             std::to_string(spec.substeps);
  k.frames.resize(n);
  for (long f = 0; f < n; ++f) {
    k.frames[f].t = times[f];
    k.frames[f].valid = true;
    k.frames[f].p = LabPoints(traj.poses[f], drive->FrameShape(static_cast<int>(f)), spec.body.link_length());
    k.frames[f].arc_length = spec.body.length;
  }
  return k;
}

}  // namespace wormdrag
