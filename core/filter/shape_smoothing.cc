#include "core/filter/shape_smoothing.h"

#include <algorithm>
#include <cmath>

#include "core/filter/shape_modes.h"

namespace wormdrag {

const char* SmoothingMethodName(SmoothingMethod m) {
  switch (m) {
    case SmoothingMethod::kAuto:
      return "auto";
    case SmoothingMethod::kLowpass:
      return "lowpass";
    case SmoothingMethod::kNone:
      return "none";
  }
  return "?";
}

Result<SmoothingMethod> ParseSmoothingMethod(const std::string& name) {
  if (name == "auto") return SmoothingMethod::kAuto;
  if (name == "lowpass") return SmoothingMethod::kLowpass;
  if (name == "none") return SmoothingMethod::kNone;
  return Status::InvalidArgument("smoothing '" + name + "' is not one of auto, lowpass, none");
}

std::string SmoothingReport::ToText() const {
  char buf[400];
  if (runs == 0) {
    std::snprintf(buf, sizeof buf, "%s", method.c_str());
  } else {
    std::snprintf(buf, sizeof buf,
                  "%s: half-power at %.3g Hz (range %.3g-%.3g Hz); tracking noise %.3g um = %.3g %% BL per coordinate",
                  method.c_str(), half_power_hz, half_power_hz_min, half_power_hz_max, noise_mm * 1e3,
                  noise_percent_bl);
  }
  return buf;
}

Json SmoothingReport::ToJson() const {
  return {{"method", method},
          {"runs", runs},
          {"frames", frames},
          {"half_power_hz", NumberOrNull(half_power_hz)},
          {"half_power_hz_min", NumberOrNull(half_power_hz_min)},
          {"half_power_hz_max", NumberOrNull(half_power_hz_max)},
          {"noise_um", NumberOrNull(noise_mm * 1e3)},
          {"noise_percent_bl", NumberOrNull(noise_percent_bl)}};
}

double TrackingNoiseByDifferences(const Kinematics& k) {
  const int n = static_cast<int>(k.frames.size());
  double best = HUGE_VAL;
  for (int order = 3; order <= 5; ++order) {
    std::vector<double> c(order + 1);  // (−1)^{order−j} C(order, j)
    double binom = 1, norm = 0;
    for (int j = 0; j <= order; ++j) {
      c[j] = ((order - j) % 2 ? -1.0 : 1.0) * binom;
      norm += binom * binom;
      binom = binom * (order - j) / (j + 1);
    }
    std::vector<double> magnitudes;
    for (int f = order; f < n; ++f) {
      bool run = true;
      for (int j = 0; j <= order && run; ++j) run = k.frames[f - order + j].valid;
      if (!run) continue;
      for (int p = 0; p < kNumPoints; ++p)
        for (int axis = 0; axis < 2; ++axis) {
          double v = 0;
          for (int j = 0; j <= order; ++j) v += c[j] * k.frames[f - order + j].p[p][axis];
          magnitudes.push_back(std::abs(v));
        }
    }
    if (magnitudes.size() < 50) continue;
    auto mid = magnitudes.begin() + magnitudes.size() / 2;
    std::nth_element(magnitudes.begin(), mid, magnitudes.end());
    // Median |N(0, σ²·Σc²)| = 0.6745 σ sqrt(Σc²).
    best = std::min(best, *mid / (0.6744897501960817 * std::sqrt(norm)));
  }
  return std::isfinite(best) ? best : 0.0;
}

namespace {

// Smooths the run's shapes q (unwrapped joint angles) in place, series by series.
void SmoothShapes(std::vector<Shape>* q, const SeriesSmoother& smooth, const ShapeModes* modes,
                  std::vector<double>* half_powers, double* dof, double fps) {
  const int len = static_cast<int>(q->size());
  std::vector<Eigen::VectorXd> a(len);
  for (int i = 0; i < len; ++i)
    a[i] = modes ? modes->ToModes((*q)[i])
                 : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>((*q)[i].data(), kNumJoints));
  std::vector<double> series(len);
  for (int j = 0; j < kNumJoints; ++j) {
    for (int i = 0; i < len; ++i) series[i] = a[i][j];
    SeriesSmoothing r = smooth(series, j);
    for (int i = 0; i < len; ++i) a[i][j] = r.z[i];
    *dof += r.dof;
    // A mode that carries only noise is flattened; its half-power says nothing.
    if (!modes || modes->snr[j] > kShapeModeSnr) half_powers->push_back(r.half_power * fps);
  }
  for (int i = 0; i < len; ++i) {
    if (modes) {
      (*q)[i] = modes->FromModes(a[i]);
    } else {
      for (int j = 0; j < kNumJoints; ++j) (*q)[i][j] = a[i][j];
    }
  }
}

// Each frame's best-fit pose and link length for its smoothed shape, and, if asked,
// those smoothed over the run (series J … J+3).
void RunPoses(const Kinematics& k, int start, const std::vector<Shape>& q, bool smooth_pose,
              const SeriesSmoother& smooth, double noise_mm, std::vector<Pose>* g, std::vector<double>* l) {
  const int len = static_cast<int>(q.size());
  g->resize(len);
  l->resize(len);
  for (int i = 0; i < len; ++i) {
    const Frame& f = k.frames[start + i];
    (*l)[i] = MeanLinkLength(f.p);
    (*g)[i] = BestFitPose(f.p, q[i], (*l)[i]);
    if (i > 0) (*g)[i].q0 = (*g)[i - 1].q0 + WrapAngle((*g)[i].q0 - (*g)[i - 1].q0);
  }
  if (!smooth_pose) return;
  auto field = [&](int i, int c) -> double& {
    Pose& p = (*g)[i];
    return c == 0 ? p.x : c == 1 ? p.y : c == 2 ? p.q0 : (*l)[i];
  };
  std::vector<double> series(len);
  for (int c = 0; c < 4; ++c) {
    for (int i = 0; i < len; ++i) series[i] = field(i, c);
    const std::vector<double> z = smooth(series, kNumJoints + c).z;
    for (int i = 0; i < len; ++i) field(i, c) = z[i];
  }
  // Noise of SD σ on both ends lengthens a link of length l by σ²/l on average.
  for (double& li : *l)
    if (li > 0) li = std::max(0.5 * li, li - noise_mm * noise_mm / li);
}

}  // namespace

Kinematics SmoothJointAngleRuns(const Kinematics& k, const SeriesSmoother& smooth, SmoothingReport* report,
                                const RunSmoothing& what) {
  Kinematics out = k;
  const int n = static_cast<int>(k.frames.size());
  std::vector<double> half_powers;
  double residual_sq = 0, dof = 0;
  int64_t coordinates = 0;
  report->runs = report->frames = 0;
  report->noise_mm = TrackingNoiseByDifferences(k);
  std::vector<Shape> q;
  std::vector<Pose> g;
  std::vector<double> l;
  for (int start = 0; start < n;) {
    if (!k.frames[start].valid) {
      ++start;
      continue;
    }
    int end = start;
    while (end < n && k.frames[end].valid) ++end;
    const int len = end - start;
    UnwrappedShapes(k, start, end, &q);
    SmoothShapes(&q, smooth, what.modes, &half_powers, &dof, k.fps);
    RunPoses(k, start, q, what.pose, smooth, report->noise_mm, &g, &l);
    for (int i = 0; i < len; ++i) {
      const Frame& f = k.frames[start + i];
      Frame& o = out.frames[start + i];
      o.p = LabPoints(g[i], q[i], l[i]);
      if (what.pose) o.arc_length = kNumLinks * l[i];
      for (int p = 0; p < kNumPoints; ++p) residual_sq += (o.p[p] - f.p[p]).squaredNorm();
    }
    coordinates += 2LL * kNumPoints * len;
    dof += 4.0 * len;  // pose (x, y, q0) and link length per frame
    report->runs += 1;
    report->frames += len;
    start = end;
  }
  if (!half_powers.empty()) {
    std::sort(half_powers.begin(), half_powers.end());
    report->half_power_hz = half_powers[half_powers.size() / 2];
    report->half_power_hz_min = half_powers.front();
    report->half_power_hz_max = half_powers.back();
  }
  const double free = static_cast<double>(coordinates) - dof;
  report->residual_mm = free > 0 ? std::sqrt(residual_sq / free) : 0;
  const double length = k.BodyLength();
  report->noise_percent_bl = length > 0 ? 100 * report->noise_mm / length : 0;
  return out;
}

Result<Kinematics> SmoothShapesAuto(const Kinematics& k, const SmoothingSplineOptions& opt, SmoothingReport* report) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  // Too short a recording to estimate the noise covariance is smoothed joint by joint.
  auto modes = NoiseWhitenedModes(k);
  Status failure = Status::Ok();
  const char* pose_names[] = {"pose x", "pose y", "pose angle", "link length"};
  Kinematics out = SmoothJointAngleRuns(
      k,
      [&](const std::vector<double>& series, int index) {
        // The amplitude cap protects a gait's fundamental; a mode that carries no
        // more shape than noise has no gait to protect, and the cap would keep its
        // noise at the periodogram's random peak.
        SmoothingSplineOptions o = opt;
        if (modes.ok() && index < kNumJoints && !(modes->snr[index] > kShapeModeSnr)) o.max_fundamental_loss = 0;
        auto s = SmoothByGcv(series, o);
        if (s.ok() && index < kNumJoints && opt.lambda_scale != 1)
          s = SmoothWithLambda(series, s->lambda * opt.lambda_scale, opt.order);
        if (!s.ok()) {
          if (failure.ok())
            failure = s.status().Annotate(index < kNumJoints
                                              ? (modes.ok() ? "shape mode " : "joint ") + std::to_string(index + 1)
                                              : pose_names[index - kNumJoints]);
          return SeriesSmoothing{series, static_cast<double>(series.size()), 0.5};
        }
        return SeriesSmoothing{std::move(s->z), s->dof, s->HalfPowerFrequency()};
      },
      report, {modes.ok() ? &*modes : nullptr, true});
  WORMDRAG_RETURN_IF_ERROR(failure);
  report->method = "auto: smoothing spline of order " + std::to_string(2 * opt.order - 1) + ", GCV per " +
                   (modes.ok() ? "noise-whitened shape mode" : "joint") + ", pose and length per run";
  out.metadata["filter"] = report->method;
  return out;
}

}  // namespace wormdrag
