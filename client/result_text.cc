#include "client/result_text.h"

#include <cmath>
#include <cstdio>

#include "core/diagnose/diagnosis.h"
#include "core/estimate/bootstrap.h"
#include "proto/result_convert.h"

namespace wormdrag::cli {
namespace {

constexpr double kNaN = NAN;

CombinationInterval IntervalOf(const char* name, const v2::Interval& i) {
  CombinationInterval c;
  c.name = name;
  c.estimate = i.has_estimate() ? i.estimate() : kNaN;
  c.corrected = i.has_corrected() ? i.corrected() : c.estimate;
  c.lo = i.has_lo() ? i.lo() : kNaN;
  c.hi = i.has_hi() ? i.hi() : kNaN;
  c.determined = i.determined();
  c.why = i.why();
  return c;
}

std::string PhaseLine(const v2::PhaseSummary& p) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "  %-14s %8lld sets  %7.1f s  best E %.6g mm", p.name().c_str(),
                static_cast<long long>(p.sets()), p.seconds(), p.best().has_e_mm() ? p.best().e_mm() : kNaN);
  std::string s = buf;
  // Phases 1-2: the work early abandoning saved.
  if (p.knots_full() > 0) {
    std::snprintf(buf, sizeof buf, "  %lld abandoned, knots %.4g of %.4g (%.1f %%)",
                  static_cast<long long>(p.abandoned()), static_cast<double>(p.knots()),
                  static_cast<double>(p.knots_full()),
                  100.0 * static_cast<double>(p.knots()) / static_cast<double>(p.knots_full()));
    s += buf;
  }
  return s + "\n";
}

std::string SmoothingLine(size_t worm, const v2::SmoothingSummary& sm) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "worm %zu: %s; tracking noise %.3g um = %.3g %% BL", worm, sm.method().c_str(),
                sm.has_noise_um() ? sm.noise_um() : kNaN, sm.has_noise_percent_bl() ? sm.noise_percent_bl() : kNaN);
  std::string s = buf;
  if (sm.runs() > 0 && sm.method().rfind("auto", 0) == 0) {
    std::snprintf(buf, sizeof buf, "; smoothing half-power %.3g Hz (range %.3g-%.3g)", sm.half_power_hz(),
                  sm.half_power_hz_min(), sm.half_power_hz_max());
    s += buf;
  }
  return s + "\n";
}

std::string ReusedLine(const v2::EstimateResult& r) {
  if (r.reused_evaluations() <= 0) return "";
  return "(" + std::to_string(r.reused_evaluations()) + " Phase 1-2 evaluations reused from the store)\n";
}

// The identifiable combinations: bootstrap intervals, or the fit's values without them.
std::string Combinations(const v2::EstimateResult& r) {
  char buf[512];
  std::string s;
  if (r.has_bootstrap()) {
    const v2::Bootstrap& b = r.bootstrap();
    std::snprintf(buf, sizeof buf, "%.0f %% intervals from %d bootstrap refits with the estimated tracking noise:\n",
                  100 * b.level(), b.replicates());
    s += buf;
    s += MisfitLine(b.has_data_e_mm() ? b.data_e_mm() : kNaN, {b.refit_e_mm().begin(), b.refit_e_mm().end()});
    s += IntervalLine(IntervalOf("K_mu", b.k_mu())) + IntervalLine(IntervalOf("K_eta", b.k_eta())) +
         IntervalLine(IntervalOf("v_c", b.v_c())) + IntervalLine(IntervalOf("scale", b.scale()));
    return s;
  }
  auto ratio = [&](const char* label, bool has, double v, const char* unit) {
    if (has && std::isfinite(v) && v > 0)
      std::snprintf(buf, sizeof buf, " %s = %.6g%s", label, v, unit);
    else
      std::snprintf(buf, sizeof buf, " %s undefined", label);
    s += buf;
  };
  const v2::Identifiability& id = r.identifiability();
  s += "identifiable (no intervals: --bootstrap 0):";
  ratio("K_mu = mu_n/mu_t", id.has_k_mu(), id.k_mu(), "");
  ratio(", K_eta = eta_n/eta_t", id.has_k_eta(), id.k_eta(), "");
  ratio(", v_c = mu_t/eta_t", id.has_v_c(), id.v_c(), " mm/s");
  return s + "\n";
}

}  // namespace

std::string EstimateResultText(const v2::EstimateResult& r) {
  char buf[512];
  const v2::FrictionCoefficients& est = r.estimate();
  std::snprintf(buf, sizeof buf,
                "friction per link: mu_n = %.6g uN, mu_t = %.6g uN, eta_n = %.6g uN.s/mm, eta_t = %.6g uN.s/mm\n"
                "path error E = %.6g mm = %.4g %% of body length\n",
                est.mu_n(), est.mu_t(), est.eta_n(), est.eta_t(), est.e_mm(), r.e_percent_bl());
  std::string s = buf;
  for (const auto& p : r.phases()) s += PhaseLine(p);
  for (int w = 0; w < r.smoothing_size(); ++w) s += SmoothingLine(static_cast<size_t>(w) + 1, r.smoothing(w));
  if (r.has_still_body()) {
    std::snprintf(buf, sizeof buf,
                  "a body that keeps its shapes but does not move: E = %.4g %% BL; skill of the fit %.3f\n",
                  r.still_body().e_percent_bl(), r.skill());
    s += buf;
    if (r.has_scale_bound()) s += "scale: " + r.scale_bound() + "\n";
    if (r.has_explains_motion() && !r.explains_motion())
      return s +
             "The fit explains the motion no better than a body that does not move: the data determine no friction "
             "ratio here. `wormdrag analyze progress` shows which part of the body's travel it misses.\n" +
             ReusedLine(r);
  }
  s += Combinations(r);
  s += "E along the scale ray (factor: E mm):";
  for (const auto& p : r.identifiability().scale_profile()) {
    std::snprintf(buf, sizeof buf, " %.3g:%.5g", p.factor(), p.e_mm());
    s += buf;
  }
  return s + "\n" + r.identifiability().summary() + "\n" + ReusedLine(r);
}

std::string DiagnosisResultText(const v2::DiagnosisResult& r) {
  char b[900];
  const v2::BaseFit& base = r.base();
  const v2::FrictionCoefficients& c = base.coefficients();
  std::string s = "verdict: " + diagnose::VerdictLabel(r.verdict(), r.confidence()) + "\n" + r.explanation() + "\n\n";
  std::snprintf(b, sizeof b,
                "base fit (quasi-static): mu_n %.4g, mu_t %.4g, eta_n %.4g, eta_t %.4g; E = %.4g mm (%.3g %% BL)\n",
                c.mu_n(), c.mu_t(), c.eta_n(), c.eta_t(), base.e_mm(), base.e_percent_bl());
  s += b;
  for (const auto& caution : r.cautions()) s += "caution: " + caution + "\n";
  const v2::HowFar& h = r.how_far();
  auto at = [](const google::protobuf::RepeatedField<double>& v, int i) { return i < v.size() ? v.Get(i) : kNaN; };
  std::snprintf(b, sizeof b,
                "how far (held-out): E %.4g mm (%.3g %% BL) -> %.4g mm (%.3g %% BL); shrink %.4g mm [%.4g, %.4g], "
                "%.0f %% of the gap above the noise floor\n",
                h.e_before_mm(), h.e_before_percent_bl(), h.e_after_mm(), h.e_after_percent_bl(), h.shrink_mm(),
                at(h.shrink_interval(), 0), at(h.shrink_interval(), 1), 100 * h.share_of_gap_above_noise());
  s += b;
  return s + "full diagnosis: `wormdrag results ID --json`\n";
}

std::string ResultText(const v2::GetResultsResponse& r) {
  switch (r.result_case()) {
    case v2::GetResultsResponse::kEstimate:
      return EstimateResultText(r.estimate());
    case v2::GetResultsResponse::kDiagnosis:
      return DiagnosisResultText(r.diagnosis());
    default:
      return "(no result)\n";
  }
}

std::string ResultJson(const v2::GetResultsResponse& r) {
  switch (r.result_case()) {
    case v2::GetResultsResponse::kEstimate:
      return rpc::ResultToJson(r.estimate());
    case v2::GetResultsResponse::kDiagnosis:
      return rpc::ResultToJson(r.diagnosis());
    default:
      return "{}";
  }
}

Result<v2::GetResultsResponse> TypedResult(const std::string& kind, const std::string& document) {
  v2::GetResultsResponse r;
  if (Status st = rpc::SetJobResult(kind, document, &r); !st.ok()) return st;
  return r;
}

}  // namespace wormdrag::cli
