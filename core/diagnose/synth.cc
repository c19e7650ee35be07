#include "core/diagnose/synth.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "core/common/format.h"
#include "core/sim/cubic_spline.h"

namespace wormdrag::diagnose {

std::vector<std::pair<int, int>> GapPattern::Runs(int frames) const {
  std::vector<std::pair<int, int>> runs;
  if (every <= 0 || length <= 0) return runs;
  for (int f = std::max(1, first); f + length < frames; f += every) runs.push_back({f, f + length - 1});
  return runs;
}

Status SynthSpec::Validate() const {
  if (!(fps > 0) || !std::isfinite(fps)) return Status::InvalidArgument("fps must be positive");
  if (!(duration > 0) || !std::isfinite(duration)) return Status::InvalidArgument("duration must be positive");
  if (duration * fps > 2e6) return Status::InvalidArgument("duration x fps is too large");
  if (!(body.length > 0)) return Status::InvalidArgument("body length must be positive");
  if (!(noise >= 0)) return Status::InvalidArgument("noise must be >= 0 mm");
  if (substeps < 1 || substeps > 64) return Status::InvalidArgument("substeps must be 1 … 64");
  if (gaps.every > 0 && gaps.length >= gaps.every)
    return Status::InvalidArgument("gap length must be below its period");
  if (!QuasiStaticSingularity(coef).empty())
    return Status::InvalidArgument("coefficients " + coef.ToString() + ": " + QuasiStaticSingularity(coef));
  return Status::Ok();
}

Result<ShapeDrive::ShapeFunction> RecordingShape(const Kinematics& k, double* t_first, double* t_last) {
  std::vector<double> ts;
  std::vector<std::vector<double>> qs(kNumJoints);
  Shape prev{};
  bool have_prev = false;
  for (const auto& fr : k.frames) {
    if (!fr.valid) continue;
    Shape q = ShapeOf(fr.p);
    if (have_prev)
      for (int j = 0; j < kNumJoints; ++j) q[j] = prev[j] + WrapAngle(q[j] - prev[j]);
    prev = q;
    have_prev = true;
    ts.push_back(fr.t);
    for (int j = 0; j < kNumJoints; ++j) qs[j].push_back(q[j]);
  }
  if (ts.size() < 2) return Status::InvalidArgument("the shape recording needs at least 2 valid frames");
  *t_first = ts.front();
  *t_last = ts.back();
  auto splines = std::make_shared<std::vector<CubicSpline>>();
  for (int j = 0; j < kNumJoints; ++j) splines->emplace_back(ts, qs[j]);
  return ShapeDrive::ShapeFunction([splines](double t, Shape* q, Shape* qd) {
    for (int j = 0; j < kNumJoints; ++j) (*splines)[j].Evaluate(t, &(*q)[j], &(*qd)[j]);
  });
}

void AddTrackingNoise(Kinematics* k, double sigma, uint64_t seed) {
  if (!(sigma > 0)) return;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  for (auto& fr : k->frames) {
    if (!fr.valid) continue;
    for (auto& p : fr.p) {
      p.x() += n(rng);
      p.y() += n(rng);
    }
  }
}

namespace {

// What drives the body, and its description for the recording's metadata.
struct ShapeSource {
  ShapeDrive::ShapeFunction shape;
  std::string text;
};

Result<ShapeSource> SourceOf(const SynthSpec& spec) {
  ShapeSource out;
  if (spec.shapes) {
    double t0 = 0, t1 = 0;
    auto s = RecordingShape(*spec.shapes, &t0, &t1);
    if (!s.ok()) return s.status();
    const double start = t0 + spec.shapes_offset;
    if (spec.shapes_offset < 0 || start + spec.duration > t1 + 1e-9) {
      char b[200];
      std::snprintf(b, sizeof b, "the shape recording covers %.4g s; offset %.4g s + duration %.4g s do not fit",
                    t1 - t0, spec.shapes_offset, spec.duration);
      return Status::InvalidArgument(b);
    }
    auto f = *s;
    out.shape = [f, start](double t, Shape* q, Shape* qd) { f(start + t, q, qd); };
    char b[120];
    std::snprintf(b, sizeof b, "joint angles of a recording from %.4g s", spec.shapes_offset);
    out.text = b;
    if (spec.shapes->metadata.count("source")) out.text += " (" + spec.shapes->metadata.at("source") + ")";
    return out;
  }
  const JointPattern pat = spec.pattern;
  out.shape = [pat](double t, Shape* q, Shape* qd) { pat.Evaluate(t, q, qd); };
  char b[160];
  std::snprintf(b, sizeof b, "q_i(t) = %g sin(%g t - %g i) + %g", pat.amplitude, pat.omega, pat.wavenumber, pat.offset);
  out.text = b;
  if (pat.envelope_depth != 0) {
    std::snprintf(b, sizeof b, ", amplitude x (1 + %g sin(2 pi %g t + %g))", pat.envelope_depth, pat.envelope_hz,
                  pat.envelope_phase);
    out.text += b;
  }
  return out;
}

Json TruthOf(const SynthSpec& spec, const std::vector<std::pair<int, int>>& runs, const std::string& source) {
  Json gaps = Json::array();
  for (const auto& r : runs) gaps.push_back(Json::array({r.first, r.second}));
  return {{"coefficients",
           {{"mu_n", NumberOrNull(spec.coef.mu_n)},
            {"mu_t", NumberOrNull(spec.coef.mu_t)},
            {"eta_n", NumberOrNull(spec.coef.eta_n)},
            {"eta_t", NumberOrNull(spec.coef.eta_t)}}},
          {"effects", spec.effects.ToJson()},
          {"effects_text", spec.effects.ToString()},
          {"noise_mm", NumberOrNull(spec.noise)},
          {"seed", spec.seed},
          {"fps", NumberOrNull(spec.fps)},
          {"duration", NumberOrNull(spec.duration)},
          {"body_length", NumberOrNull(spec.body.length)},
          {"substeps", spec.substeps},
          {"gaps", gaps},
          {"source", source}};
}

}  // namespace

Result<SynthOutput> Synthesize(const SynthSpec& spec) {
  WORMDRAG_RETURN_IF_ERROR(spec.Validate());
  const int n = static_cast<int>(std::lround(spec.duration * spec.fps)) + 1;
  std::vector<double> times(n);
  for (int f = 0; f < n; ++f) times[f] = f / spec.fps;
  auto source = SourceOf(spec);
  if (!source.ok()) return source.status();
  const auto runs = spec.gaps.Runs(n);
  auto drive = EffectDrive::FromFunction(times, source->shape, spec.body, spec.initial, spec.substeps, runs);
  if (!drive.ok()) return drive.status();
  EffectSimOptions so;
  so.epsilon = spec.epsilon;
  const EffectTrajectory tr = SimulateEffects(*drive, spec.coef, spec.effects, so);
  if (!tr.ok())
    return Status::Internal("the velocity solver did not converge at " + std::to_string(tr.unconverged) + " knots");
  SynthOutput out;
  Kinematics& k = out.clean;
  k.fps = spec.fps;
  k.metadata["source"] = "wormdrag synth: " + source->text;
  k.metadata["coefficients"] = spec.coef.ToString();
  k.metadata["effects"] = spec.effects.ToString();
  k.frames.resize(n);
  for (int f = 0; f < n; ++f) {
    k.frames[f].t = times[f];
    k.frames[f].valid = true;
    k.frames[f].p = EffectPoints(*drive, tr, f);
    k.frames[f].arc_length = tr.link_length[f] * kNumLinks;
  }
  out.recording = k;
  for (const auto& r : runs)
    for (int f = r.first; f <= r.second; ++f) out.recording.frames[f].valid = false;
  AddTrackingNoise(&out.recording, spec.noise, spec.seed);
  out.recording.metadata["noise_mm"] = FormatNumber(spec.noise, 6);
  out.recording.metadata["seed"] = std::to_string(spec.seed);
  out.truth = TruthOf(spec, runs, source->text);
  return out;
}

}  // namespace wormdrag::diagnose
