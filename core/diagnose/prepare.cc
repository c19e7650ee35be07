// Data preparation: truncation to the analysed span, short gaps interpolated for the
// filter, the low-pass of the joint angles, the frames the fits use, the time blocks, and
// the tracking noise σ.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/diagnose/internal/stages.h"
#include "core/filter/butterworth.h"
#include "core/io/gaps.h"

namespace wormdrag::diagnose {
namespace {

using internal::kPi;

// Sum of squared changes (rad²) the low-pass made to the joint angles of the valid
// frames, and their count: what fast motion and noise the drive loses.
void AddAngleChange(const Kinematics& before, const Kinematics& after, const std::vector<bool>& valid, double* sq,
                    long* n) {
  for (size_t f = 0; f < valid.size() && f < before.frames.size() && f < after.frames.size(); ++f) {
    if (!valid[f]) continue;
    const Shape a = ShapeOf(before.frames[f].p), b = ShapeOf(after.frames[f].p);
    for (int j = 0; j < kNumJoints; ++j) {
      const double d = std::remainder(b[j] - a[j], 2 * kPi);
      *sq += d * d;
      ++*n;
    }
  }
}

// Preprocessing of one recording: truncate, (interpolate short gaps to smooth across
// them), smooth (DiagnoseOptions::smoothing), and mark the interpolated frames missing
// again. `change_sq` and `change_n` accumulate the smoothing's change to the angles
// (AddAngleChange).
Result<Kinematics> Prepare(const Kinematics& raw, double t_max, const DiagnoseOptions& o, const std::string& name,
                           double* change_sq, long* change_n) {
  Kinematics k = raw.Truncated(t_max);
  std::vector<bool> valid(k.frames.size());
  for (size_t f = 0; f < k.frames.size(); ++f) valid[f] = k.frames[f].valid;
  if (o.interpolate_gaps > 0) InterpolateShortGaps(k, o.interpolate_gaps);
  Result<Kinematics> smoothed = k;
  if (o.smoothing == SmoothingMethod::kAuto) {
    SmoothingReport report;
    smoothed = SmoothShapesAuto(k, o.spline, &report);
  } else if (o.smoothing == SmoothingMethod::kLowpass && o.lowpass_hz > 0) {
    if (!(o.lowpass_hz < 0.5 * k.fps)) {
      char b[160];
      std::snprintf(b, sizeof b, "%s: low-pass cut-off %.4g Hz must be below half the frame rate (%.4g fps)",
                    name.c_str(), o.lowpass_hz, k.fps);
      return Status::InvalidArgument(b);
    }
    AngleFilterOptions fo;
    fo.cutoff_hz = o.lowpass_hz;
    smoothed = FilterJointAngles(k, fo);
  }
  if (!smoothed.ok()) return smoothed.status().Annotate(name);
  AddAngleChange(k, *smoothed, valid, change_sq, change_n);
  k = std::move(*smoothed);
  for (size_t f = 0; f < k.frames.size(); ++f)
    if (!valid[f]) k.frames[f].valid = false;
  return k;
}

}  // namespace

int BlockCount(const DiagnoseOptions& o, double span_s) {
  if (o.blocks > 0) return o.blocks;
  const long n = std::lround(span_s / kBlockSeconds);
  return static_cast<int>(std::clamp<long>(n, kMinBlocks, kMaxBlocks));
}

double EstimateTrackingNoise(const Kinematics& k) {
  std::vector<double> d2;
  for (size_t f = 1; f + 1 < k.frames.size(); ++f) {
    const auto &a = k.frames[f - 1], &b = k.frames[f], &c = k.frames[f + 1];
    if (!a.valid || !b.valid || !c.valid) continue;
    for (int p = 0; p < kNumPoints; ++p) {
      const Vec2 d = a.p[p] - 2 * b.p[p] + c.p[p];
      d2.push_back(d.x());
      d2.push_back(d.y());
    }
  }
  if (d2.size() < 10) return 0;
  const size_t mid = d2.size() / 2;
  std::nth_element(d2.begin(), d2.begin() + mid, d2.end());
  const double med = d2[mid];
  for (double& x : d2) x = std::abs(x - med);
  std::nth_element(d2.begin(), d2.begin() + mid, d2.end());
  return 1.4826 * d2[mid] / std::sqrt(6.0);
}

std::vector<int> FitFrames(const Kinematics& k, double fit_hz) {
  const int n = static_cast<int>(k.frames.size());
  const int stride = fit_hz > 0 && k.fps > 0 ? std::max(1, static_cast<int>(std::lround(k.fps / fit_hz))) : 1;
  std::vector<int> out;
  out.reserve(n / stride + 8);
  for (int f = 0; f < n; ++f) {
    const bool valid = k.frames[f].valid;
    const bool prev_valid = f > 0 && k.frames[f - 1].valid, next_valid = f + 1 < n && k.frames[f + 1].valid;
    const bool keep = stride == 1 || f % stride == 0 || f == n - 1 || (valid && f > 0 && !prev_valid) ||
                      (valid && f + 1 < n && !next_valid) || (!valid && (f == 0 || prev_valid));
    if (keep) out.push_back(f);
  }
  return out;
}

Result<EffectData> PrepareEffectData(const std::array<Kinematics, 2>& k_full, const std::vector<int>& points,
                                     int substeps, int blocks, double fit_hz) {
  EffectData d;
  d.blocks = blocks;
  // Subsample the frames the fits use (all of them when fit_hz does not thin them).
  std::array<Kinematics, 2> k;
  std::array<std::vector<int>, 2> sources;
  for (int j = 0; j < 2; ++j) {
    sources[j] = FitFrames(k_full[j], fit_hz);
    if (sources[j].size() == k_full[j].frames.size()) {
      k[j] = k_full[j];
      sources[j].clear();
      continue;
    }
    k[j].metadata = k_full[j].metadata;
    const double stride = std::max(1.0, std::round(k_full[j].fps / fit_hz));
    k[j].fps = k_full[j].fps / stride;
    for (int f : sources[j]) k[j].frames.push_back(k_full[j].frames[f]);
  }
  for (int j = 0; j < 2; ++j) {
    BodyModel body;
    // The body length of every valid frame (not only the kept ones), as at full rate.
    body.length = k_full[j].BodyLength();
    if (!(body.length > 0))
      return Status::InvalidArgument("recording " + std::to_string(j + 1) + " has no valid frame");
    auto drive = EffectDrive::FromKinematics(k[j], body, substeps);
    if (!drive.ok()) return drive.status().Annotate("recording " + std::to_string(j + 1));
    EffectRecording& w = d.worms[j];
    w.drive = std::make_shared<const EffectDrive>(std::move(*drive));
    w.kinematics = k[j];
    if (!sources[j].empty()) {
      w.full = k_full[j];
      w.source_frames = sources[j];
    }
    const ShapeDrive& sd = w.drive->drive();
    const double t0 = k[j].frames[sd.first_frame()].t, T = k[j].frames[sd.last_frame()].t - t0;
    int last_block = 0;
    for (int f = sd.first_frame(); f <= sd.last_frame(); ++f) {
      if (!k[j].frames[f].valid) continue;
      const int b = std::min(blocks - 1, static_cast<int>((k[j].frames[f].t - t0) / T * blocks));
      if (b != last_block) {
        w.block_starts.push_back(f);
        last_block = b;
      }
      EffectRecording::Scored s;
      s.frame = f;
      s.block = b;
      const Points model = HeadFramePoints(sd.FrameShape(f), body.link_length());
      for (int p : points) {
        s.measured.push_back(k[j].frames[f].p[p]);
        s.model.push_back(model[p]);
      }
      w.frames.push_back(std::move(s));
    }
    if (w.frames.size() < static_cast<size_t>(2 * blocks))
      return Status::InvalidArgument("recording " + std::to_string(j + 1) + " has too few valid frames for " +
                                     std::to_string(blocks) + " blocks");
  }
  d.body_length = 0.5 * (d.worms[0].drive->drive().body().length + d.worms[1].drive->drive().body().length);
  return d;
}

Result<EffectData> PrepareForDiagnosis(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o) {
  double t_max = o.t_max;
  for (const auto& k : recordings) t_max = std::min(t_max, k.Duration());
  return internal::PreparePair(recordings, t_max, o, {"recording 1", "recording 2"});
}

namespace internal {

Result<EffectData> PreparePair(const std::array<Kinematics, 2>& raw, double t_max, const DiagnoseOptions& o,
                               const std::array<std::string, 2>& names, std::array<Kinematics, 2>* prepared_out) {
  std::array<Kinematics, 2> prepared;
  double sq = 0;
  long n = 0;
  for (int j = 0; j < 2; ++j) {
    auto k = Prepare(raw[j], t_max, o, names[j], &sq, &n);
    if (!k.ok()) return k.status();
    prepared[j] = std::move(*k);
  }
  const double span = std::min(prepared[0].Duration(), prepared[1].Duration());
  auto data = PrepareEffectData(prepared, o.points, o.substeps, BlockCount(o, span), o.fit_hz);
  if (data.ok()) data->smoothing_change_rad = n ? std::sqrt(sq / n) : 0.0;
  if (prepared_out) *prepared_out = std::move(prepared);
  return data;
}

Status PrepareRecordings(DiagnosisRun* run) {
  const DiagnoseOptions& o = run->o;
  Diagnosis& out = run->out;
  run->t_max = o.t_max;
  for (const auto& k : run->recordings) {
    if (k.frames.empty()) return Status::InvalidArgument("a recording has no frames");
    run->t_max = std::min(run->t_max, k.Duration());
  }
  if (o.noise_sigma >= 0) {
    out.noise_sigma = o.noise_sigma;
    out.noise_estimated = false;
  } else {
    out.noise_sigma = 0.5 * (EstimateTrackingNoise(run->recordings[0].Truncated(run->t_max)) +
                             EstimateTrackingNoise(run->recordings[1].Truncated(run->t_max)));
  }
  auto data = PreparePair(run->recordings, run->t_max, o, out.names, &run->prepared);
  if (!data.ok()) return data.status();
  run->data = std::move(*data);
  run->replicate_data = {&run->data};
  out.body_length = run->data.body_length;
  out.blocks = run->data.blocks;
  // N frames cover N / fps seconds (the last frame's interval counts).
  out.span_s = run->t_max;
  for (const auto& k : run->prepared) out.span_s = std::min(out.span_s, k.Duration() + 1 / k.fps);
  if (out.span_s < kReliableSpanSeconds - 1e-6) {
    char b[300];
    std::snprintf(b, sizeof b,
                  "The recordings give %.3g s per worm; verdicts were right far less often on the benchmark's 2 s "
                  "pairs than on its %.3g s pairs (docs/diagnose.md, \"Recording length\"): record at least %.3g s "
                  "per worm.",
                  out.span_s, kReliableSpanSeconds, kReliableSpanSeconds);
    out.cautions.push_back(b);
  }
  run->tested = TestedEffects(o);
  return Status::Ok();
}

}  // namespace internal
}  // namespace wormdrag::diagnose
