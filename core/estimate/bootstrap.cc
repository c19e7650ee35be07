#include "core/estimate/bootstrap.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <nlohmann/json.hpp>

#include "core/sim/simulator.h"

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The q-quantile of n sorted values at the plotting position q (n + 1) among the order
// statistics 1 … n (Hyndman & Fan's type 6; linear between them, clamped to the extremes;
// ±inf allowed). A new draw from the values' distribution falls between the k-th and
// l-th order statistics with probability (l − k) / (n + 1), so the q and 1 − q quantiles
// at these positions hold it with probability 1 − 2q, whatever the distribution: the
// basic interval's coverage is its level. The usual position q (n − 1) + 1 (type 7)
// gives 20 refits' 5 % and 95 % quantiles a coverage of 81 %, not 90 %
// (test Bootstrap.IntervalsHoldTheTruthAsOftenAsTheirLevelSays).
double Quantile(const std::vector<double>& sorted, double q) {
  const double n = static_cast<double>(sorted.size());
  const double pos = std::clamp(q * (n + 1) - 1, 0.0, n - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const double f = pos - i;
  if (i + 1 >= sorted.size() || f == 0) return sorted[i];
  if (!std::isfinite(sorted[i]) || !std::isfinite(sorted[i + 1])) return f < 0.5 ? sorted[i] : sorted[i + 1];
  return sorted[i] + f * (sorted[i + 1] - sorted[i]);
}

// Basic bootstrap interval of a positive combination g, in log space.
CombinationInterval Interval(const std::string& name, double estimate, std::vector<double> values,
                             const BootstrapOptions& opt, double bias_share) {
  CombinationInterval r;
  r.name = name;
  r.estimate = r.corrected = estimate;
  if (!(estimate > 0) || !std::isfinite(estimate)) {
    r.lo = 0;
    r.hi = kInf;
    r.why = std::isnan(estimate) ? "undefined at the fit (both of its coefficients are 0)"
                                 : "at a bound at the fit (a coefficient of the ratio is 0)";
    return r;
  }
  if (values.empty()) {
    r.lo = 0;
    r.hi = kInf;
    r.why = "no replicate finished";
    return r;
  }
  // A refit with an undefined ratio (0/0) is as far from the fit as the bounds.
  std::vector<double> logs;
  int undefined = 0;
  for (double v : values) {
    if (std::isnan(v)) ++undefined;
    logs.push_back(std::isnan(v) ? -kInf : std::log(v));  // placed low; checked below
  }
  std::sort(logs.begin(), logs.end());
  const double a = (1 - opt.level) / 2;
  const double q_lo = Quantile(logs, a), q_hi = Quantile(logs, 1 - a);
  const double theta = std::log(estimate), m = Quantile(logs, 0.5);
  const double centre = std::isfinite(m) ? theta - bias_share * (m - theta) : theta;
  r.lo = std::exp(centre - (q_hi - m));
  r.hi = std::exp(centre + (m - q_lo));
  // With most refits at a bound the median is infinite and an end is ∞ − ∞: the mirrored
  // spread is unbounded there, so that end is the bound.
  if (std::isnan(r.lo)) r.lo = 0;
  if (std::isnan(r.hi)) r.hi = kInf;
  r.corrected = std::exp(centre);
  char buf[200];
  if (std::isfinite(q_lo) && std::isfinite(q_hi) && q_hi - q_lo < 1e-9 && std::abs(m - theta) > 1e-9) {
    // Refits that all land on one value away from the fit do not respond to their data.
    r.corrected = estimate;
    r.lo = 0, r.hi = kInf, r.why = "every refit lands on the same other value: the data do not move it";
  } else if (undefined > 0 && undefined >= static_cast<int>(std::ceil(a * values.size()))) {
    std::snprintf(buf, sizeof buf, "%d of %zu refits leave it undefined", undefined, values.size());
    r.lo = 0, r.hi = kInf, r.why = buf;
  } else if (!std::isfinite(q_lo) || !std::isfinite(q_hi)) {
    r.why = "its interval reaches a bound (refits with a coefficient of the ratio at 0)";
  } else if (r.hi > opt.max_ratio * r.lo) {
    std::snprintf(buf, sizeof buf, "its %.0f %% interval spans a factor %.3g (more than %.3g)", 100 * opt.level,
                  r.hi / r.lo, opt.max_ratio);
    r.why = buf;
  } else {
    r.determined = true;
  }
  return r;
}

// "hi" is +inf where the interval reaches no bound: written "inf", which readers of stored
// results tell apart from a missing value (null).
Json IntervalJson(const CombinationInterval& c) {
  Json j = {{"estimate", NumberOrNull(c.estimate)},
            {"corrected", NumberOrNull(c.corrected)},
            {"lo", NumberOrNull(c.lo)},
            {"hi", NumberOrInf(c.hi)},
            {"determined", c.determined}};
  if (!c.why.empty()) j["why"] = c.why;
  return j;
}

// The tangential Coulomb share of the drag at link speed v (mm/s).
double CoulombShare(double v_c, double v) {
  return std::isinf(v_c) ? 1.0 : v_c / (v_c + v);
}

}  // namespace

int MinReplicates(double level) {
  return static_cast<int>(std::ceil(2 / (1 - level) - 1 - 1e-9));
}

Status BootstrapOptions::Validate() const {
  if (replicates < 0 || replicates > 10000) return Status::InvalidArgument("bootstrap replicates must be 0 … 10000");
  if (!(level > 0.5 && level < 1)) return Status::InvalidArgument("bootstrap level must lie between 0.5 and 1");
  const int min_replicates = MinReplicates(level);
  if (replicates > 0 && replicates < min_replicates) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "bootstrap replicates must be 0 (off) or at least %d for a %g %% interval: n refits hold a new "
                  "one with probability (n − 1) / (n + 1) at most",
                  min_replicates, 100 * level);
    return Status::InvalidArgument(buf);
  }
  if (!(noise_floor_percent_bl >= 0)) return Status::InvalidArgument("bootstrap noise floor must be >= 0");
  if (!(max_ratio > 1)) return Status::InvalidArgument("bootstrap max_ratio must exceed 1");
  if (check_replicates < 0 || check_replicates > 1000)
    return Status::InvalidArgument("bootstrap check_replicates must be 0 … 1000");
  if (!(check_factor > 1)) return Status::InvalidArgument("bootstrap check_factor must exceed 1");
  if (!(smoothing_check == 0 || (smoothing_check > 1 && smoothing_check < 1e3)))
    return Status::InvalidArgument("bootstrap smoothing_check must be 0 (off) or lie in (1, 1000)");
  return Status::Ok();
}

double CoefficientScale(const Coefficients& c, double d_mu, double d_eta) {
  return c.mu_n / d_mu + c.mu_t / d_mu + c.eta_n / d_eta + c.eta_t / d_eta;
}

Result<std::array<Kinematics, 2>> MakeReplicate(const PairedPath& pair, const Coefficients& c,
                                                const std::array<double, 2>& noise_mm, uint64_t seed) {
  std::array<Kinematics, 2> out;
  std::mt19937_64 rng(seed);
  for (int j = 0; j < 2; ++j) {
    const ScoredRecording& w = pair.worm(j);
    const Trajectory t = Simulator::Simulate(w.drive, c, pair.options().sim, &w.resets);
    if (!t.summary.ok())
      return Status::FailedPrecondition(w.name +
                                        ": the fitted model cannot be simulated: " + t.summary.OneLineReport());
    std::normal_distribution<double> noise(0, noise_mm[j]);
    Kinematics& k = out[j];
    k.fps = w.kinematics.fps;
    k.metadata = w.kinematics.metadata;
    k.metadata["source"] = "bootstrap replicate of " + w.name;
    const double l = w.drive.body().link_length();
    for (size_t f = 0; f < w.kinematics.frames.size(); ++f) {
      Frame fr;
      fr.t = w.kinematics.frames[f].t;
      const int i = static_cast<int>(f);
      fr.valid = w.kinematics.frames[f].valid && i >= w.drive.first_frame() && i <= w.drive.last_frame();
      if (fr.valid) {
        Points p = LabPoints(t.poses[i - t.first_frame], w.drive.FrameShape(i), l);
        std::vector<Vec2> line(p.begin(), p.end());
        for (Vec2& v : line) v += Vec2(noise(rng), noise(rng));
        fr.arc_length = ArcLength(line);
        auto resampled = ResampleByArcLength(line);
        if (!resampled.ok()) return resampled.status().Annotate(w.name + " replicate frame " + std::to_string(f));
        fr.p = *resampled;
      }
      k.frames.push_back(fr);
    }
  }
  return out;
}

BootstrapReport SummariseBootstrap(const Coefficients& est, const std::vector<Coefficients>& fits,
                                   const std::vector<bool>& ok, double d_mu, double d_eta, const BootstrapOptions& opt,
                                   double bias_share, double link_speed) {
  BootstrapReport r;
  r.level = opt.level;
  std::vector<double> k_mu, k_eta, v_c, scale;
  const double s0 = CoefficientScale(est, d_mu, d_eta);
  for (size_t i = 0; i < fits.size(); ++i) {
    if (!ok[i]) {
      ++r.failed;
      continue;
    }
    ++r.replicates;
    r.fits.push_back(fits[i]);
    k_mu.push_back(fits[i].K_mu());
    k_eta.push_back(fits[i].K_eta());
    v_c.push_back(fits[i].v_c());
    scale.push_back(CoefficientScale(fits[i], d_mu, d_eta) / s0);
  }
  r.K_mu = Interval("K_mu", est.K_mu(), k_mu, opt, bias_share);
  r.K_eta = Interval("K_eta", est.K_eta(), k_eta, opt, bias_share);
  r.v_c = Interval("v_c", est.v_c(), v_c, opt, bias_share);
  r.scale = Interval("scale", 1.0, scale, opt, bias_share);
  r.link_speed = link_speed;
  const double fit_v_c = est.v_c();
  if (link_speed > 0 && fit_v_c >= 0) {
    const double coulomb = CoulombShare(fit_v_c, link_speed);
    char buf[200];
    auto drop = [&](CombinationInterval* c, const char* part, double share) {
      if (share >= opt.min_force_share || !c->determined) return;
      std::snprintf(buf, sizeof buf, "%s is only %.2g %% of the drag at the median link speed (%.3g mm/s)", part,
                    100 * share, link_speed);
      c->determined = false;
      c->why = buf;
    };
    drop(&r.K_mu, "Coulomb friction", coulomb);
    drop(&r.K_eta, "viscous drag", 1 - coulomb);
    // The crossover speed lies among the body's speeds only when both parts count.
    drop(&r.v_c, coulomb < 0.5 ? "Coulomb friction" : "viscous drag", std::min(coulomb, 1 - coulomb));
  }
  RequireCrossover(est, opt, &r);
  return r;
}

void RequireCrossover(const Coefficients& estimate, const BootstrapOptions& opt, BootstrapReport* report) {
  const double v_c = estimate.v_c();
  if (!(report->link_speed > 0) || !(v_c >= 0) || report->v_c.determined) return;
  const double coulomb = CoulombShare(v_c, report->link_speed);
  if (std::min(coulomb, 1 - coulomb) < opt.min_force_share) return;
  char buf[300];
  std::snprintf(buf, sizeof buf,
                "both parts of the law carry the drag (Coulomb %.2g %% at the median link speed, %.3g mm/s) and "
                "the crossover speed v_c that divides it between them is not determined: each ratio describes one "
                "part, and it trades against v_c",
                100 * coulomb, report->link_speed);
  for (CombinationInterval* c : {&report->K_mu, &report->K_eta}) {
    if (!c->determined) continue;
    c->determined = false;
    c->why = buf;
  }
}

void CheckMisfit(double data_e, const std::vector<double>& fit_e, BootstrapReport* report) {
  report->data_e = data_e;
  report->fit_e = fit_e;
  double highest = -HUGE_VAL;
  for (double e : fit_e)
    if (std::isfinite(e)) highest = std::max(highest, e);
  report->misfit_explained = !(std::isfinite(highest) && data_e > highest);
  if (report->misfit_explained) return;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "the data's path error (E %.4g mm) exceeds every refit's against its replicate (at most %.4g mm): "
                "part of the misfit is not tracking noise (shape detail the smoothing removed, or an effect the "
                "model lacks), and replicates that carry tracking noise alone understate the uncertainty",
                data_e, highest);
  for (CombinationInterval* c : {&report->K_mu, &report->K_eta, &report->v_c, &report->scale}) {
    if (!c->determined) continue;
    c->determined = false;
    c->why = buf;
  }
}

Json BootstrapReport::ToJson() const {
  Json j = {{"replicates", replicates},
            {"failed", failed},
            {"check_refits", check_refits},
            {"level", level},
            {"noise_um", {noise_mm[0] * 1e3, noise_mm[1] * 1e3}},
            {"K_mu", IntervalJson(K_mu)},
            {"K_eta", IntervalJson(K_eta)},
            {"v_c", IntervalJson(v_c)},
            {"scale", IntervalJson(scale)}};
  Json f = Json::array();
  for (const auto& c : fits) f.push_back({c.mu_n, c.mu_t, c.eta_n, c.eta_t});
  j["fits"] = f;
  Json sm = Json::array();
  for (const auto& [scale, c] : smoothing_fits)
    sm.push_back({{"lambda_scale", scale}, {"fit", c ? Json{c->mu_n, c->mu_t, c->eta_n, c->eta_t} : Json()}});
  j["smoothing_check"] = sm;
  Json ch = Json::array();
  for (const CheckGroup& g : checks)
    ch.push_back({{"name", g.name},
                  {"value", NumberOrNull(g.value)},
                  {"refits_lo", NumberOrNull(g.lo)},
                  {"refits_hi", NumberOrNull(g.hi)}});
  j["checks"] = ch;
  j["data_E_mm"] = NumberOrNull(data_e);
  Json fe = Json::array();
  for (double e : fit_e) fe.push_back(NumberOrNull(e));
  j["refit_E_mm"] = fe;
  j["misfit_explained"] = misfit_explained;
  return j;
}

std::string BootstrapReport::ToText() const {
  std::string s;
  char buf[300];
  std::snprintf(buf, sizeof buf, "%.0f %% intervals from %d bootstrap refits (%d failed; noise %.3g / %.3g um):\n",
                100 * level, replicates, failed, noise_mm[0] * 1e3, noise_mm[1] * 1e3);
  s += buf;
  s += MisfitLine(data_e, fit_e);
  for (const CombinationInterval* c : {&K_mu, &K_eta, &v_c, &scale}) s += IntervalLine(*c);
  return s;
}

std::string MisfitLine(double data_e, const std::vector<double>& fit_e) {
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double e : fit_e)
    if (std::isfinite(e)) lo = std::min(lo, e), hi = std::max(hi, e);
  if (!(lo <= hi) || !std::isfinite(data_e)) return "";
  char buf[300];
  std::snprintf(buf, sizeof buf, "  misfit          the data's E %.4g mm, the refits' %.4g-%.4g mm%s\n", data_e, lo, hi,
                data_e > hi ? ": above every refit, so part of it is not tracking noise" : "");
  return buf;
}

std::string IntervalLine(const CombinationInterval& c) {
  char buf[400];
  const char* unit = c.name == "v_c" ? " mm/s" : "";
  const std::string label = c.name == "scale" ? "scale (factor)" : c.name;
  if (c.determined) {
    std::snprintf(buf, sizeof buf, "  %-15s %.4g%s  [%.4g, %.4g]  (fit %.4g, bias-corrected by the refits)\n",
                  label.c_str(), c.corrected, unit, c.lo, c.hi, c.estimate);
  } else if (std::isfinite(c.estimate) && c.estimate > 0) {
    std::snprintf(buf, sizeof buf, "  %-15s not determined (fit %.4g%s; %s)\n", label.c_str(), c.estimate, unit,
                  c.why.c_str());
  } else {
    std::snprintf(buf, sizeof buf, "  %-15s not determined (%s)\n", label.c_str(), c.why.c_str());
  }
  return buf;
}

}  // namespace wormdrag
