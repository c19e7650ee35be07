#include "core/diagnose/effects.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/common/format.h"
#include "core/model/body.h"

namespace wormdrag::diagnose {

const std::vector<EffectInfo>& AllEffects() {
  static const std::vector<EffectInfo> kAll = {
      {Effect::kBodyGradient, "body_gradient", true, {"a"}, {0}, {-1.8}, {1.8}, {0.1}, ""},
      {Effect::kTimeDrift, "time_drift", true, {"a"}, {0}, {-1.8}, {1.8}, {0.1}, ""},
      {Effect::kPowerLaw, "power_law", true, {"n"}, {1}, {0.05}, {2.5}, {0.1}, ""},
      {Effect::kStiction, "stiction", true, {"a"}, {0}, {-0.9}, {8}, {0.1}, ""},
      {Effect::kLag, "lag", true, {"delta"}, {0}, {-0.3}, {0.5}, {0.01}, "s"},
      {Effect::kFlow, "flow", true, {"w_x", "w_y"}, {0, 0}, {-2, -2}, {2, 2}, {0.01, 0.01}, "mm/s"},
      {Effect::kGapOffset, "gap_offset", true, {"a"}, {0}, {-1}, {4}, {0.1}, ""},
      {Effect::kLateralAsymmetry, "lateral_asymmetry", true, {"a"}, {0}, {-0.6}, {1.9}, {0.1}, ""},
      {Effect::kStretch, "stretch", false, {"A"}, {0}, {0}, {0.5}, {0.01}, ""},
      {Effect::kTether, "tether", false, {"k"}, {0}, {0}, {1e3}, {0.1}, "uN/mm"},
      {Effect::kBoundary, "boundary", false, {"A"}, {0}, {-0.9}, {20}, {0.1}, ""},
  };
  return kAll;
}

const EffectInfo& InfoOf(Effect e) {
  return AllEffects()[static_cast<int>(e)];
}

Result<Effect> ParseEffectName(const std::string& name) {
  for (const auto& i : AllEffects())
    if (name == i.name) return i.effect;
  std::string known;
  for (const auto& i : AllEffects()) known += (known.empty() ? "" : ", ") + std::string(i.name);
  return Status::InvalidArgument("unknown effect '" + name + "' (known: " + known + ")");
}

std::vector<double> GetParams(const EffectParams& p, Effect e) {
  switch (e) {
    case Effect::kBodyGradient:
      return {p.body_gradient};
    case Effect::kTimeDrift:
      return {p.time_drift};
    case Effect::kPowerLaw:
      return {p.power_law ? p.power_n : 1.0};
    case Effect::kStiction:
      return {p.stiction};
    case Effect::kLag:
      return {p.lag};
    case Effect::kFlow:
      return {p.flow_x, p.flow_y};
    case Effect::kGapOffset:
      return {p.gap_offset};
    case Effect::kLateralAsymmetry:
      return {p.lateral_asymmetry};
    case Effect::kStretch:
      return {p.stretch};
    case Effect::kTether:
      return {p.tether};
    case Effect::kBoundary:
      return {p.boundary};
  }
  return {};
}

void SetParams(EffectParams* p, Effect e, const std::vector<double>& v) {
  switch (e) {
    case Effect::kBodyGradient:
      p->body_gradient = v[0];
      break;
    case Effect::kTimeDrift:
      p->time_drift = v[0];
      break;
    case Effect::kPowerLaw:
      p->power_law = true;
      p->power_n = v[0];
      break;
    case Effect::kStiction:
      p->stiction = v[0];
      break;
    case Effect::kLag:
      p->lag = v[0];
      break;
    case Effect::kFlow:
      p->flow_x = v[0];
      p->flow_y = v.size() > 1 ? v[1] : 0;
      break;
    case Effect::kGapOffset:
      p->gap_offset = v[0];
      break;
    case Effect::kLateralAsymmetry:
      p->lateral_asymmetry = v[0];
      break;
    case Effect::kStretch:
      p->stretch = v[0];
      break;
    case Effect::kTether:
      p->tether = v[0];
      break;
    case Effect::kBoundary:
      p->boundary = v[0];
      break;
  }
}

bool EffectParams::Has(Effect e) const {
  if (e == Effect::kPowerLaw) return power_law;
  for (double v : GetParams(*this, e))
    if (v != 0) return true;
  return false;
}

bool EffectParams::IsNeutral() const {
  for (const auto& i : AllEffects())
    if (Has(i.effect)) return false;
  return true;
}

std::string EffectParams::ToString() const {
  std::string s;
  for (const auto& i : AllEffects()) {
    if (!Has(i.effect)) continue;
    s += s.empty() ? "" : ";";
    s += i.name;
    s += "=";
    const auto v = GetParams(*this, i.effect);
    for (size_t k = 0; k < v.size(); ++k) {
      char b[40];
      std::snprintf(b, sizeof b, "%s%.6g", k ? "," : "", v[k]);
      s += b;
    }
  }
  return s.empty() ? "none" : s;
}

Json EffectParams::ToJson() const {
  Json j = Json::object();
  for (const auto& i : AllEffects()) {
    if (!Has(i.effect)) continue;
    const auto v = GetParams(*this, i.effect);
    Json params = Json::object();
    for (size_t k = 0; k < v.size(); ++k) params[i.params[k]] = NumberOrNull(v[k]);
    j[i.name] = params;
  }
  return j;
}

Result<EffectParams> ParseEffects(const std::vector<std::string>& items) {
  EffectParams p;
  std::vector<std::string> parts;
  for (const auto& item : items) {
    for (std::string& part : SplitList(item, ';'))
      if (!part.empty()) parts.push_back(std::move(part));
  }
  for (const auto& part : parts) {
    if (part == "none") continue;
    const auto eq = part.find('=');
    if (eq == std::string::npos)
      return Status::InvalidArgument("effect '" + part + "': expected NAME=VALUE (e.g. body_gradient=0.5)");
    auto e = ParseEffectName(part.substr(0, eq));
    if (!e.ok()) return e.status();
    const EffectInfo& info = InfoOf(*e);
    std::vector<double> values;
    for (const std::string& tok : SplitList(part.substr(eq + 1))) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (tok.empty() || *end != '\0' || !std::isfinite(v))
        return Status::InvalidArgument("effect " + std::string(info.name) + ": '" + tok + "' is not a number");
      values.push_back(v);
    }
    if (values.size() != info.params.size())
      return Status::InvalidArgument("effect " + std::string(info.name) + " takes " +
                                     std::to_string(info.params.size()) + " value(s), got " +
                                     std::to_string(values.size()));
    for (size_t k = 0; k < values.size(); ++k)
      if (values[k] < info.lower[k] || values[k] > info.upper[k]) {
        char b[200];
        std::snprintf(b, sizeof b, "effect %s: %s = %g is outside [%g, %g]", info.name, info.params[k], values[k],
                      info.lower[k], info.upper[k]);
        return Status::InvalidArgument(b);
      }
    SetParams(&p, *e, values);
  }
  return p;
}

double BodyGradientFactor(double a, int link) {
  const double s = (link - 0.5) / kNumLinks;
  return 1.0 + a * (s - 0.5);
}

void EffectForce(double v, double mu, double eta, bool normal, const EffectParams& p, double eps, double* f,
                 double* dfdv) {
  const double s = std::sqrt(v * v + eps * eps);
  const double sg = v / s;  // sgnε(v)
  const double dsg = eps * eps / (s * s * s);
  // Coulomb multiplier M(v) and its derivative.
  double M = 1, dM = 0;
  if (p.stiction != 0) {
    const double x = v / kStictionVs, e = std::exp(-x * x);
    M = 1 + p.stiction * e;
    dM = p.stiction * e * (-2 * x / kStictionVs);
  }
  if (normal && p.lateral_asymmetry != 0) {
    const double w = 0.5 * (1 + sg), dw = 0.5 * dsg;
    const double A = 1 + p.lateral_asymmetry * w;
    dM = dM * A + M * p.lateral_asymmetry * dw;
    M *= A;
  }
  if (!p.power_law) {
    *f = mu * M * sg + eta * v;
    *dfdv = mu * (dM * sg + M * dsg) + eta;
    return;
  }
  // Power law: (μ M + η v_ref) sgnε(v) |v/v_ref|^n.
  const double n = p.power_n;
  const double av = std::abs(v);
  const double r = av > 0 ? std::pow(av / kPowerLawVRef, n) : 0.0;
  const double C = mu * M + eta * kPowerLawVRef;
  // d/dv [sgnε(v) |v|^n] / v_ref^n = r (ε²/s³ + n/s)
  *f = C * sg * r;
  *dfdv = mu * dM * sg * r + C * r * (dsg + n / s);
}

}  // namespace wormdrag::diagnose
