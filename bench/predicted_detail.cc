// --predicted-detail: can the shape detail the smoothing removes be predicted from the
// smoothed shapes themselves? Decision 0032 finds the agar-like bias in the timing of
// that detail against the gait. Detail locked to the gait is a function of the gait's
// state, so it may be regressed on the smoothed shape modes (monomials up to degree 3 of
// the modes that carry shape: the harmonics a travelling wave's nonlinearity makes).
// The tracking noise is independent of those regressors, so the regression of the
// residual raw − smoothed estimates the same function as the regression of the true
// lost detail clean − smoothed, from many frames.
#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "bench/replicate_setup.h"
#include "core/filter/shape_modes.h"

namespace wormdrag::bench {
namespace {

constexpr int kMaxCarriers = 4;

// With harmonics H > 0: 1, every standardised carrier, and the first H harmonics of the
// gait's phase φ (the angle of the two strongest carriers), each alone and times their
// amplitude r: cos hφ, sin hφ, r cos hφ, r sin hφ. A waveform that is not a pure sine
// repeats its detail at the same phase of every cycle, at harmonics of the gait, however
// the gait's frequency drifts. With H = 0: 1, then every monomial of degree 1 to 3 of the
// standardised carriers.
Eigen::VectorXd Features(const Eigen::VectorXd& a, const std::vector<int>& carry, const std::vector<double>& sd,
                         int harmonics) {
  std::vector<double> z;
  for (size_t i = 0; i < carry.size(); ++i) z.push_back(a[carry[i]] / sd[i]);
  std::vector<double> f = {1};
  const int k = static_cast<int>(z.size());
  if (harmonics > 0) {
    for (double v : z) f.push_back(v);
    if (k < 2) return Eigen::Map<Eigen::VectorXd>(f.data(), f.size());
    const double phi = std::atan2(z[1], z[0]), r = std::hypot(z[0], z[1]);
    for (int h = 1; h <= harmonics; ++h)
      for (double v : {std::cos(h * phi), std::sin(h * phi)}) {
        f.push_back(v);
        f.push_back(r * v);
      }
    return Eigen::Map<Eigen::VectorXd>(f.data(), f.size());
  }
  for (int i = 0; i < k; ++i) {
    f.push_back(z[i]);
    for (int j = i; j < k; ++j) {
      f.push_back(z[i] * z[j]);
      for (int l = j; l < k; ++l) f.push_back(z[i] * z[j] * z[l]);
    }
  }
  return Eigen::Map<Eigen::VectorXd>(f.data(), f.size());
}

struct Restored {
  Kinematics k;
  double oracle_r2 = 0;  // share of the lost detail's variance the features can explain
  double skill = 0;      // 1 − ‖lost − predicted from noise‖² / ‖lost‖²
};

// The smoothed recording with the detail predicted from the noisy residual put back
// into the modes that carry shape, with the regression's R² and skill; unchanged when a
// frame is missing or no mode carries shape.
Restored Restore(const Kinematics& raw, const Kinematics& smooth, const Kinematics& clean, int harmonics) {
  Restored out{smooth};
  auto modes = NoiseWhitenedModes(raw);
  if (!modes.ok()) return out;
  for (const Frame& f : raw.frames)
    if (!f.valid) return out;
  const int n = static_cast<int>(smooth.frames.size());
  Eigen::MatrixXd as = ModeSeries(*modes, smooth);
  const Eigen::MatrixXd ar = ModeSeries(*modes, raw), ac = ModeSeries(*modes, clean);
  std::vector<int> carry;
  for (int m = kNumJoints - 1; m >= 0 && static_cast<int>(carry.size()) < kMaxCarriers; --m)
    if (modes->snr[m] > kShapeModeSnr) carry.push_back(m);
  if (carry.empty()) return out;
  std::vector<double> sd;
  for (int m : carry) {
    double s2 = 0;
    for (int i = 0; i < n; ++i) s2 += as(i, m) * as(i, m) / n;
    sd.push_back(std::sqrt(s2) + 1e-12);
  }
  const int p = static_cast<int>(Features(as.row(0).transpose(), carry, sd, harmonics).size());
  Eigen::MatrixXd F(n, p);
  for (int i = 0; i < n; ++i) F.row(i) = Features(as.row(i).transpose(), carry, sd, harmonics).transpose();
  const auto qr = F.colPivHouseholderQr();
  double lost = 0, unexplained = 0, missed = 0;
  for (int m : carry) {
    const Eigen::VectorXd noisy = ar.col(m) - as.col(m), truth = ac.col(m) - as.col(m);
    const Eigen::VectorXd predicted = F * qr.solve(noisy), best = F * qr.solve(truth);
    lost += truth.squaredNorm();
    unexplained += (truth - best).squaredNorm();
    missed += (truth - predicted).squaredNorm();
    as.col(m) += predicted;
  }
  out.oracle_r2 = 1 - unexplained / lost;
  out.skill = 1 - missed / lost;
  out.k = WithModeShapes(smooth, *modes, as);
  return out;
}

}  // namespace

int PredictedDetailRows(const Setup& s, int n, int harmonics) {
  std::vector<double> r2(n, NAN), skill(n, NAN);
  const std::vector<double> restored = Parallel(n, [&](int i) {
    auto d = Draw(s, s.seed + 100 * (i + 1));
    if (!d.ok()) return double(NAN);
    const std::array<Kinematics, 2> raw = {(*d)[0].recording, (*d)[1].recording};
    auto smoothed = Smoothed(raw, s.options);
    if (!smoothed.ok()) return double(NAN);
    std::array<Kinematics, 2> k;
    r2[i] = skill[i] = 0;
    for (int w = 0; w < 2; ++w) {
      Restored r = Restore(raw[w], (*smoothed)[w], (*d)[w].clean, harmonics);
      r2[i] += r.oracle_r2 / 2, skill[i] += r.skill / 2;
      k[w] = std::move(r.k);
    }
    auto pair = PairOf(s, k, false, s.options);
    return pair.ok() ? FitFromTruth(s, *pair) : double(NAN);
  });
  std::printf("| refits of | values, sorted |\n|---|---|\n");
  PrintRow("fresh noise draws of the data", Parallel(n, [&](int i) { return FreshDrawFit(s, i, s.options); }));
  PrintRow("the same draws with the predicted detail put back", restored);
  std::printf(
      "\n| draw | lost detail the features explain (R², from the clean shapes) | predicted from the noisy data (skill) "
      "|\n|---|---|---|\n");
  for (int i = 0; i < n; ++i) std::printf("| %d | %.3f | %.3f |\n", i, r2[i], skill[i]);
  return 0;
}

}  // namespace wormdrag::bench
