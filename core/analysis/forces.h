// Friction forces on the body over time (the paper's §4, Fig. 12): per link, in the
// lab frame, from a simulation of one recording with one coefficient set.
//
// At every frame the simulator's rigid velocity ξ = (V_x, V_y, ω) (head frame) gives
// each friction term's velocity v = jx·V_x + jy·V_y + jw·ω + b (term 2k tangential
// of link k+1, 2k+1 normal) and its force f = −μ sgnε(v) − η v (docs/conventions.md §1); the link's
// force vector is f_t t_k + f_n n_k, rotated into the lab frame by the pose.
//
// What identifiability allows (docs/conventions.md §2): multiplying all four coefficients by c
// leaves the path unchanged (without inertia, exactly) and multiplies every force by
// c. The data fix the *shape* of these curves, not their absolute size; forces are
// in µN "at the estimated scale", which rests on inertia alone.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/model/body.h"
#include "core/model/friction_law.h"
#include "core/sim/shape_drive.h"
#include "core/sim/simulator.h"

namespace wormdrag {

struct LinkForceSeries {
  Coefficients coefficients;
  double body_length = 0;                               // mm
  std::vector<int> frame;                               // recording frame index
  std::vector<double> t;                                // s
  std::vector<std::array<Vec2, kNumLinks>> force;       // lab frame, µN, link 1 … N
  std::vector<std::array<double, kNumLinks>> f_t, f_n;  // tangential / normal components, µN
  std::vector<Vec2> net;                                // Σ_k f_k (µN): equals the rate of change of momentum, ≈ 0
  std::vector<double> net_moment;                       // Σ_k (c_k − p_0) × f_k, µN·mm
  std::vector<double> magnitude_sum;                    // Σ_k |f_k|, µN
  std::vector<double> thrust;           // Σ_k max(0, f_k · u), u = direction of the centroid's velocity, µN
  std::vector<double> power;            // −Σ_k f_k · v(c_k): power dissipated by friction, µN·mm/s (= nW)
  std::vector<Vec2> centroid_velocity;  // mm/s, lab frame
  // false at the first frame of each simulated stretch (the start and every restart after
  // a gap): the body starts at rest, so that frame carries the start-up acceleration;
  // such frames are left out of the summaries below.
  std::vector<bool> summarized;
  // Summaries over the summarized frames: RMS over links and frames of |f_k|, RMS of |net|, means.
  double rms_link = 0, rms_net = 0, mean_magnitude_sum = 0, mean_thrust = 0, mean_power = 0;
  SimSummary sim;
};

// Simulates the drive with `c` (velocities recorded) and evaluates the forces at every
// simulated frame. `resets` as for Simulator::Simulate (may be null).
Result<LinkForceSeries> ComputeLinkForces(const ShapeDrive& drive, const Coefficients& c, const SimOptions& opt,
                                          const PoseResets* resets = nullptr);

// The forces at one knot for velocity ξ, in the head frame (link 1 along +x), per
// link; also the link centres' velocities. Pure (tested against FrictionWrench).
void HeadFrameLinkForces(const KnotGeometry& g, const Shape& q, const Coefficients& c, double eps,
                         const std::array<double, 3>& xi, std::array<Vec2, kNumLinks>* force,
                         std::array<Vec2, kNumLinks>* velocity, std::array<double, kNumLinks>* f_t,
                         std::array<double, kNumLinks>* f_n);

// CSV: t, then per link fx,fy,ft,fn, then net_x, net_y, magnitude_sum, thrust, power.
std::string LinkForcesCsv(const LinkForceSeries& s);

}  // namespace wormdrag
