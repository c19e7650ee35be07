// The truth the noise-only replicates simulate: the data's prepared shapes, or a
// periodic gait fitted to them when the gait explains the raw shapes down to the noise
// (docs/decisions/0038-periodic-gait-null-truth.md).
#include <cmath>

#include <Eigen/Dense>

#include "core/diagnose/diagnosis.h"
#include "core/filter/smoothing_spline.h"
#include "core/model/body.h"

namespace wormdrag::diagnose {
namespace {

// Harmonics of the gait's frequency in the periodic fit: three hold a steady travelling
// wave's shape while the fit's parameters per joint (8) stay few against the hundreds of
// frames of a recording.
constexpr int kGaitHarmonics = 3;
constexpr int kGaitParams = 2 + 2 * kGaitHarmonics;

// Columns: 1, t and the cosine and sine of each harmonic of f0 (Hz).
Eigen::MatrixXd GaitDesign(const std::vector<double>& t, double f0) {
  Eigen::MatrixXd a(t.size(), kGaitParams);
  for (size_t i = 0; i < t.size(); ++i) {
    a(i, 0) = 1;
    a(i, 1) = t[i];
    for (int h = 1; h <= kGaitHarmonics; ++h) {
      a(i, 2 * h) = std::cos(2 * M_PI * h * f0 * t[i]);
      a(i, 2 * h + 1) = std::sin(2 * M_PI * h * f0 * t[i]);
    }
  }
  return a;
}

// The gait's frequency (Hz): the middle joint's periodogram peak, refined to the
// frequency whose fit leaves that joint the least residual (the peak's resolution is one
// cycle per recording, too coarse for a fit over all of it).
double GaitFrequency(const std::vector<double>& t, const std::vector<Shape>& shapes, double fps) {
  std::vector<double> mid;
  for (const Shape& q : shapes) mid.push_back(q[kNumJoints / 2]);
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(mid.data(), mid.size());
  const double peak = DominantFrequency(mid) * fps;
  double best_f = peak, best = INFINITY;
  for (int k = -250; k <= 250; ++k) {
    const double f = peak * (1 + 1e-3 * k);
    const Eigen::MatrixXd a = GaitDesign(t, f);
    const double r = (a * a.colPivHouseholderQr().solve(y) - y).squaredNorm();
    if (r < best) {
      best = r;
      best_f = f;
    }
  }
  return best_f;
}

// The least-squares gait of each joint of `shapes` at times `t`.
std::vector<Shape> FitGait(const std::vector<double>& t, const std::vector<Shape>& shapes, double f0) {
  const Eigen::MatrixXd a = GaitDesign(t, f0);
  const auto qr = a.colPivHouseholderQr();
  std::vector<Shape> fitted(shapes.size());
  for (int q = 0; q < kNumJoints; ++q) {
    Eigen::VectorXd y(shapes.size());
    for (size_t i = 0; i < shapes.size(); ++i) y(i) = shapes[i][q];
    const Eigen::VectorXd z = a * qr.solve(y);
    for (size_t i = 0; i < shapes.size(); ++i) fitted[i][q] = z(i);
  }
  return fitted;
}

// Joint q of `r` at frames `index` (increasing), bridged linearly over the frames
// missing between them so that the samples stay equally spaced for GCV.
std::vector<double> Bridged(const std::vector<int>& index, const std::vector<Shape>& r, int q) {
  std::vector<double> y;
  for (size_t i = 0; i < index.size(); ++i) {
    if (i > 0)
      for (int f = index[i - 1] + 1; f < index[i]; ++f)
        y.push_back(r[i - 1][q] + (r[i][q] - r[i - 1][q]) * (f - index[i - 1]) / (index[i] - index[i - 1]));
    y.push_back(r[i][q]);
  }
  return y;
}

// The raw shapes' residual variance about their gait over the noise variance GCV finds
// in that residual: ≈ 1 when the gait explains all but the noise.
double GaitExcess(const std::vector<int>& index, const std::vector<double>& t, const std::vector<Shape>& raw,
                  double f0) {
  const std::vector<Shape> gait = FitGait(t, raw, f0);
  std::vector<Shape> r(raw.size());
  for (size_t i = 0; i < raw.size(); ++i)
    for (int q = 0; q < kNumJoints; ++q) r[i][q] = raw[i][q] - gait[i][q];
  SmoothingSplineOptions gcv;
  gcv.max_fundamental_loss = 0;  // the residual has no gait left to protect
  double residual = 0, noise = 0;
  for (int q = 0; q < kNumJoints; ++q) {
    for (const Shape& x : r) residual += x[q] * x[q] / static_cast<double>(r.size() - kGaitParams);
    auto z = SmoothByGcv(Bridged(index, r, q), gcv);
    if (!z.ok()) return INFINITY;
    noise += z->noise_sd * z->noise_sd;
  }
  return noise > 0 ? residual / noise : INFINITY;
}

}  // namespace

Result<EffectData> NullTruth(const std::array<Kinematics, 2>& recordings, const EffectData& data,
                             const DiagnoseOptions& o, double max_excess, std::array<double, 2>* excess) {
  std::array<Kinematics, 2> truth;
  bool any = false;
  for (int j = 0; j < 2; ++j) {
    truth[j] = data.worms[j].FullRate();
    Kinematics& k = truth[j];
    const Kinematics& raw = recordings[j];
    // The valid frames of both, matched by time.
    std::vector<int> frames, index;
    std::vector<double> t;
    std::vector<Shape> prepared, measured;
    for (int f = 0; f < static_cast<int>(k.frames.size()); ++f) {
      if (!k.frames[f].valid || raw.frames.empty()) continue;
      const long i = std::lround((k.frames[f].t - raw.frames[0].t) * raw.fps);
      if (i < 0 || i >= static_cast<long>(raw.frames.size()) || !raw.frames[i].valid ||
          std::abs(raw.frames[i].t - k.frames[f].t) > 0.25 / raw.fps)
        continue;
      frames.push_back(f);
      index.push_back(static_cast<int>(i));
      t.push_back(k.frames[f].t);
      prepared.push_back(ShapeOf(k.frames[f].p));
      measured.push_back(ShapeOf(raw.frames[i].p));
    }
    double x = INFINITY;
    double f0 = 0;
    if (frames.size() > static_cast<size_t>(4 * kGaitParams)) {
      f0 = GaitFrequency(t, prepared, k.fps);
      x = GaitExcess(index, t, measured, f0);
    }
    if (excess) (*excess)[j] = x;
    if (!(x <= max_excess)) continue;
    any = true;
    const std::vector<Shape> gait = FitGait(t, prepared, f0);
    for (size_t i = 0; i < frames.size(); ++i) {
      Frame& fr = k.frames[frames[i]];
      const double l = MeanLinkLength(fr.p);
      fr.p = LabPoints(BestFitPose(fr.p, prepared[i], l), gait[i], l);
    }
  }
  if (!any) return data;
  // Already prepared: assembled as they are.
  DiagnoseOptions as_is = o;
  as_is.smoothing = SmoothingMethod::kNone;
  return PrepareForDiagnosis(truth, as_is);
}

}  // namespace wormdrag::diagnose
