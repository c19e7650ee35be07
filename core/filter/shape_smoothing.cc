#include "core/filter/shape_smoothing.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

namespace wormdrag {

const char* SmoothingMethodName(SmoothingMethod m) {
  switch (m) {
    case SmoothingMethod::kAuto: return "auto";
    case SmoothingMethod::kLowpass: return "lowpass";
    case SmoothingMethod::kNone: return "none";
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
                  "%s: half-power at %.3g Hz (joints %.3g-%.3g Hz); tracking noise %.3g um = %.3g %% BL per coordinate",
                  method.c_str(), half_power_hz, half_power_hz_min, half_power_hz_max, noise_mm * 1e3,
                  noise_percent_bl);
  }
  return buf;
}

std::string SmoothingReport::ToJson() const {
  nlohmann::json j = {{"method", method},
                      {"runs", runs},
                      {"frames", frames},
                      {"half_power_hz", half_power_hz},
                      {"half_power_hz_min", half_power_hz_min},
                      {"half_power_hz_max", half_power_hz_max},
                      {"noise_um", noise_mm * 1e3},
                      {"noise_percent_bl", noise_percent_bl}};
  return j.dump();
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

Kinematics SmoothJointAngleRuns(const Kinematics& k, const SeriesSmoother& smooth, SmoothingReport* report) {
  Kinematics out = k;
  const int n = static_cast<int>(k.frames.size());
  std::vector<double> half_powers;
  double residual_sq = 0, dof = 0;
  int64_t coordinates = 0;
  report->runs = report->frames = 0;
  for (int start = 0; start < n;) {
    if (!k.frames[start].valid) { ++start; continue; }
    int end = start;
    while (end < n && k.frames[end].valid) ++end;
    const int len = end - start;
    // Joint angles of the run, unwrapped over time.
    std::vector<Shape> q(len);
    for (int i = 0; i < len; ++i) q[i] = ShapeOf(k.frames[start + i].p);
    for (int i = 1; i < len; ++i)
      for (int j = 0; j < kNumJoints; ++j) q[i][j] = q[i - 1][j] + WrapAngle(q[i][j] - q[i - 1][j]);
    std::vector<double> series(len);
    for (int j = 0; j < kNumJoints; ++j) {
      for (int i = 0; i < len; ++i) series[i] = q[i][j];
      SeriesSmoothing s = smooth(series, j);
      for (int i = 0; i < len; ++i) q[i][j] = s.z[i];
      dof += s.dof;
      half_powers.push_back(s.half_power * k.fps);
    }
    for (int i = 0; i < len; ++i) {
      const Frame& f = k.frames[start + i];
      const double l = MeanLinkLength(f.p);
      out.frames[start + i].p = LabPoints(BestFitPose(f.p, q[i], l), q[i], l);
      for (int p = 0; p < kNumPoints; ++p) residual_sq += (out.frames[start + i].p[p] - f.p[p]).squaredNorm();
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
  report->noise_mm = TrackingNoiseByDifferences(k);
  const double length = k.BodyLength();
  report->noise_percent_bl = length > 0 ? 100 * report->noise_mm / length : 0;
  return out;
}

Result<Kinematics> SmoothShapesAuto(const Kinematics& k, const SmoothingSplineOptions& opt, SmoothingReport* report) {
  WORMDRAG_RETURN_IF_ERROR(opt.Validate());
  Status failure = Status::Ok();
  Kinematics out = SmoothJointAngleRuns(
      k,
      [&](const std::vector<double>& series, int joint) {
        auto s = SmoothByGcv(series, opt);
        if (!s.ok()) {
          if (failure.ok()) failure = s.status().Annotate("joint " + std::to_string(joint + 1));
          return SeriesSmoothing{series, static_cast<double>(series.size()), 0.5};
        }
        return SeriesSmoothing{std::move(s->z), s->dof, s->HalfPowerFrequency()};
      },
      report);
  WORMDRAG_RETURN_IF_ERROR(failure);
  report->method = "auto: smoothing spline of order " + std::to_string(2 * opt.order - 1) + ", GCV per joint and run";
  out.metadata["filter"] = report->method;
  return out;
}

}  // namespace wormdrag
