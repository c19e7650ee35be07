// Where: the base fit's residual broken down by body point, time, direction, frequency
// band, gait phase and the low-pass, each cell beside its noise-only floor.
#include <cmath>
#include <cstdio>

#include "core/diagnose/internal/stages.h"

namespace wormdrag::diagnose::internal {
namespace {

// |X_k|² of the DFT of x about its mean m, by direct summation.
double DftPower(const std::vector<double>& x, double m, int k) {
  const int N = static_cast<int>(x.size());
  double re = 0, im = 0;
  for (int i = 0; i < N; ++i) {
    const double a = 2 * kPi * k * i / N;
    re += (x[i] - m) * std::cos(a);
    im -= (x[i] - m) * std::sin(a);
  }
  return re * re + im * im;
}

// Power of x in frequency bands (Hz edges) by a direct DFT (mean removed).
std::vector<double> BandRms(const std::vector<double>& x, double fps, const std::vector<double>& edges) {
  const int N = static_cast<int>(x.size());
  std::vector<double> out(edges.size() + 1, 0.0);
  if (N < 4) return out;
  const double m = Mean(x);
  for (int k = 1; k <= N / 2; ++k) {
    const double f = k * fps / N;
    const double p = (k == N / 2 && N % 2 == 0 ? 1.0 : 2.0) * DftPower(x, m, k) / (double(N) * N);
    size_t b = 0;
    while (b < edges.size() && f >= edges[b]) ++b;
    out[b] += p;
  }
  for (double& v : out) v = std::sqrt(v);
  return out;
}

double GaitFrequency(const EffectData& d) {
  std::vector<double> peaks;
  for (const auto& w : d.worms) {
    // Joint 6 sampled uniformly in time (a subsampled fit's frames are not uniform).
    const double fps = w.kinematics.fps;
    const int N = std::max(2, static_cast<int>(std::lround(w.drive->span() * fps)) + 1);
    std::vector<double> q(N);
    for (int i = 0; i < N; ++i) {
      Shape s, sdot;
      w.drive->ShapeAt(w.drive->t0() + i / fps, &s, &sdot);
      q[i] = s[5];
    }
    const double m = Mean(q);
    double best = 0, bf = 0;
    for (int k = 1; k <= N / 2; ++k) {
      const double p = DftPower(q, m, k);
      if (p > best) {
        best = p;
        bf = k * fps / N;
      }
    }
    peaks.push_back(bf);
  }
  return Mean(peaks);
}

// Fills NaN entries linearly between their valid neighbours (by the nearest at the ends).
void FillGapsLinearly(std::vector<double>& v) {
  int last = -1;
  for (int i = 0; i < static_cast<int>(v.size()); ++i) {
    if (std::isnan(v[i])) continue;
    if (last < 0)
      for (int k = 0; k < i; ++k) v[k] = v[i];
    else
      for (int k = last + 1; k < i; ++k) v[k] = v[last] + (v[i] - v[last]) * (k - last) / double(i - last);
    last = i;
  }
  if (last < 0)
    std::fill(v.begin(), v.end(), 0.0);
  else
    for (size_t k = last + 1; k < v.size(); ++k) v[k] = v[last];
}

// The residual's sums over both worms, from which the breakdowns are formed.
struct WhereSums {
  static constexpr int kTimeBins = 10, kPhaseBins = 8;
  explicit WhereSums(double gait_hz) : edges{0.5 * gait_hz, 1.5 * gait_hz, 3.5 * gait_hz}, band_sq(4, 0) {}

  std::vector<double> pt_sq = std::vector<double>(kNumPoints, 0);
  int frames = 0;
  std::vector<double> time_sum = std::vector<double>(kTimeBins, 0), phase_sum = std::vector<double>(kPhaseBins, 0);
  std::vector<int> time_n = std::vector<int>(kTimeBins, 0), phase_n = std::vector<int>(kPhaseBins, 0);
  double tan_sq = 0, nor_sq = 0, trans_sq = 0, head_sq = 0;
  int directions = 0;
  std::vector<double> edges;  // of the frequency bands, Hz
  std::vector<double> band_sq;
};

// One frame's residual: its mean distance, the mean offset (translation) and the
// rotation about the centroids (heading, rad).
struct FrameResidual {
  double mean_d = 0;
  Vec2 trans = Vec2::Zero();
  double heading = 0;
};

FrameResidual AddFrame(const Points& P, const Points& S, double L, WhereSums* sums) {
  FrameResidual out;
  Vec2 cp = Vec2::Zero(), cs = Vec2::Zero();
  for (int k = 0; k < kNumPoints; ++k) {
    const Vec2 r = P[k] - S[k];
    sums->pt_sq[k] += r.squaredNorm();
    out.mean_d += r.norm() / kNumPoints;
    out.trans += r / kNumPoints;
    cp += P[k] / kNumPoints;
    cs += S[k] / kNumPoints;
    Vec2 tg = P[std::min(k + 1, kNumPoints - 1)] - P[std::max(k - 1, 0)];
    tg.normalize();
    const double rt = r.dot(tg), rn = r.x() * -tg.y() + r.y() * tg.x();
    sums->tan_sq += rt * rt;
    sums->nor_sq += rn * rn;
    ++sums->directions;
  }
  double sdot = 0, scross = 0;
  for (int k = 0; k < kNumPoints; ++k) {
    const Vec2 a = S[k] - cs, b = P[k] - cp;
    sdot += a.dot(b);
    scross += a.x() * b.y() - a.y() * b.x();
  }
  out.heading = std::atan2(scross, sdot);
  sums->trans_sq += out.trans.squaredNorm();
  sums->head_sq += (out.heading * L / 2) * (out.heading * L / 2);  // as an arc at half the body length
  ++sums->frames;
  return out;
}

// One worm's residual along its path: per frame, then the spectra of its translation
// and heading, and the speed of the translation by gait phase (joint 6: atan2 of its
// rate, scaled, and value).
void AddWorm(const EffectRecording& rec, const EffectTrajectory& tr, double L, double gait_hz, WhereSums* sums,
             std::vector<double>* t, std::vector<double>* mm) {
  const ShapeDrive& sd = rec.drive->drive();
  const auto& fr = rec.kinematics.frames;
  const double t0 = fr[sd.first_frame()].t, T = std::max(1e-9, fr[sd.last_frame()].t - t0);
  const int N = sd.num_frames();
  std::vector<double> sx(N, NAN), sy(N, NAN), sh(N, NAN);
  std::vector<double> q6(N);
  for (int i = 0; i < N; ++i) q6[i] = sd.FrameShape(sd.first_frame() + i)[5];
  for (int i = 0; i < N; ++i) {
    const int f = sd.first_frame() + i;
    if (!fr[f].valid) continue;
    const FrameResidual r = AddFrame(fr[f].p, EffectPoints(*rec.drive, tr, f), L, sums);
    const int tb = std::min(WhereSums::kTimeBins - 1, static_cast<int>((fr[f].t - t0) / T * WhereSums::kTimeBins));
    sums->time_sum[tb] += r.mean_d;
    sums->time_n[tb]++;
    sx[i] = r.trans.x();
    sy[i] = r.trans.y();
    sh[i] = r.heading * L / 2;
    t->push_back(fr[f].t);
    mm->push_back(r.mean_d);
  }
  // Gaps filled linearly for the spectra and the rates.
  FillGapsLinearly(sx);
  FillGapsLinearly(sy);
  FillGapsLinearly(sh);
  const double fps = rec.kinematics.fps;
  for (const auto* s : {&sx, &sy, &sh}) {
    const auto b = BandRms(*s, fps, sums->edges);
    for (size_t k = 0; k < b.size(); ++k) sums->band_sq[k] += b[k] * b[k];
  }
  const double q6m = Mean(q6);
  const double wg = 2 * kPi * std::max(gait_hz, 1e-3);
  for (int i = 0; i + 1 < N; ++i) {
    const double rate = std::hypot(sx[i + 1] - sx[i], sy[i + 1] - sy[i]) * fps;
    const double dq = (q6[std::min(i + 1, N - 1)] - q6[std::max(i - 1, 0)]) * fps / 2;
    double ph = std::atan2(-dq / wg, q6[i] - q6m);
    if (ph < 0) ph += 2 * kPi;
    const int pb = std::min(WhereSums::kPhaseBins - 1, static_cast<int>(ph / (2 * kPi) * WhereSums::kPhaseBins));
    sums->phase_sum[pb] += rate;
    sums->phase_n[pb]++;
  }
}

std::vector<Breakdown> Breakdowns(const WhereSums& s, double path_mse, double smoothing_change_rad) {
  const int nfr = std::max(1, s.frames), ndir = std::max(1, s.directions);
  Breakdown whole{"whole path", "mm", {{"all points (RMS)", std::sqrt(path_mse)}}};
  Breakdown by_point{"body point", "mm", {}}, by_time{"time", "mm", {}}, by_dir{"direction", "mm", {}},
      by_band{"frequency band", "mm", {}}, by_phase{"gait phase", "mm/s", {}},
      by_lowpass{"smoothing", "rad", {{"joint-angle change (RMS)", smoothing_change_rad}}};
  for (int k = 0; k < kNumPoints; ++k) by_point.cells.push_back({"p" + std::to_string(k), std::sqrt(s.pt_sq[k] / nfr)});
  for (int b = 0; b < WhereSums::kTimeBins; ++b) {
    char l[40];
    std::snprintf(l, sizeof l, "%d-%d%%", b * 10, b * 10 + 10);
    by_time.cells.push_back({l, s.time_n[b] ? s.time_sum[b] / s.time_n[b] : 0.0});
  }
  by_dir.cells.push_back({"tangential", std::sqrt(s.tan_sq / ndir)});
  by_dir.cells.push_back({"normal", std::sqrt(s.nor_sq / ndir)});
  by_dir.cells.push_back({"translation", std::sqrt(s.trans_sq / nfr)});
  by_dir.cells.push_back({"heading (x L/2)", std::sqrt(s.head_sq / nfr)});
  const char* bl[] = {"drift (<0.5 f_gait)", "gait (0.5-1.5 f_gait)", "harmonics (1.5-3.5 f_gait)",
                      "high (>3.5 f_gait)"};
  for (size_t k = 0; k < s.band_sq.size(); ++k) by_band.cells.push_back({bl[k], std::sqrt(s.band_sq[k] / 6.0)});
  for (int b = 0; b < WhereSums::kPhaseBins; ++b) {
    char l[40];
    std::snprintf(l, sizeof l, "%d-%d deg", b * 45, b * 45 + 45);
    by_phase.cells.push_back({l, s.phase_n[b] ? s.phase_sum[b] / s.phase_n[b] : 0.0});
  }
  return {whole, by_point, by_time, by_dir, by_band, by_phase, by_lowpass};
}

}  // namespace

WhereValues ComputeWhere(const EffectData& d, const Coefficients& c, double eps, double gait_hz) {
  WhereValues w;
  WhereSums sums(gait_hz);
  w.t.resize(2);
  w.mm.resize(2);
  std::vector<GapWindow> at_gaps, elsewhere;
  for (int j = 0; j < 2; ++j) {
    const auto& rec = d.worms[j];
    const EffectTrajectory tr = Run(rec, c, {}, false, eps);
    if (!tr.ok()) continue;
    AddGapWindows(rec, tr, &at_gaps, &elsewhere);
    AddWorm(rec, tr, d.body_length, gait_hz, &sums, &w.t[j], &w.mm[j]);
  }
  double all_sq = 0;
  for (int k = 0; k < kNumPoints; ++k) all_sq += sums.pt_sq[k];
  w.path_mse = all_sq / (kNumPoints * std::max(1, sums.frames));
  w.breakdowns = Breakdowns(sums, w.path_mse, d.smoothing_change_rad);
  w.gap = SummariseGapWindows(at_gaps, elsewhere);
  return w;
}

void MeasureWhere(DiagnosisRun* run) {
  Diagnosis& out = run->out;
  out.gait_hz = GaitFrequency(run->data);
  run->where = ComputeWhere(run->data, out.base, run->o.epsilon, out.gait_hz);
  out.path_mse = run->where.path_mse;
  out.residual_t = run->where.t;
  out.residual_mm = run->where.mm;
  out.gap_signature = run->where.gap;
}

void AddNullToWhere(DiagnosisRun* run) {
  Diagnosis& out = run->out;
  out.where = run->where.breakdowns;
  for (size_t b = 0; b < out.where.size(); ++b)
    for (size_t c = 0; c < out.where[b].cells.size(); ++c) {
      std::vector<double> v;
      for (const auto& nw : run->null_where) v.push_back(nw.breakdowns[b].cells[c].value);
      out.where[b].cells[c].null_mean = Mean(v);
      // A cell that noise leaves at 0 in all but one replicate has no spread to bound:
      // its largest replicate value marks it.
      const double bound = NoiseBound(run->o.false_alarm_rate, v);
      out.where[b].cells[c].null_hi = std::isfinite(bound) || v.empty() ? bound : *std::max_element(v.begin(), v.end());
    }
  std::vector<double> path;
  for (const auto& nw : run->null_where) path.push_back(nw.path_mse);
  out.null_path_mses = path;
  out.null_path_mse = path.empty() ? 0 : Mean(path);
  out.null_path_sd = path.size() > 1 ? Sd(path) : 0;
  out.null_gap_z.clear();
  for (const auto& nw : run->null_where)
    if (nw.gap.Measured()) out.null_gap_z.push_back(nw.gap.Z());
}

}  // namespace wormdrag::diagnose::internal
