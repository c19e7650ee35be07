#include "core/estimate/identifiability.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Eigenvalues>

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const char* kNames[4] = {"mu_n", "mu_t", "eta_n", "eta_t"};

// Relative change of a combination with direction u (in log coordinates) that
// raises E by `rise_mm`, from the curvature uᵀHu; ∞ if E does not rise that way.
double Tolerance(const Eigen::MatrixXd& H, const Eigen::VectorXd& u, double rise_mm) {
  const double curv = u.dot(H * u) / u.squaredNorm();
  if (!(curv > 0)) return kInf;
  return std::exp(std::sqrt(2 * rise_mm / curv)) - 1;
}

// The sets of one batch: the scale profile's, then the Hessian's central-difference
// stencil in the log coordinates (±h along each; the four corners of each pair).
std::vector<Coefficients> ProfileAndStencil(const Coefficients& c, const std::vector<int>& log_coordinates,
                                            const IdentifiabilityOptions& opt) {
  std::vector<Coefficients> sets;
  for (double f : opt.scale_factors) sets.push_back(c.Scaled(f));
  const auto a = c.AsArray();
  const int m = static_cast<int>(log_coordinates.size());
  const double h = opt.log_step;
  auto shifted = [&](int i, double di, int j, double dj) {
    auto v = a;
    v[log_coordinates[i]] *= std::exp(di);
    if (j >= 0) v[log_coordinates[j]] *= std::exp(dj);
    return Coefficients::FromArray(v);
  };
  for (int i = 0; i < m; ++i) {
    sets.push_back(shifted(i, h, -1, 0));
    sets.push_back(shifted(i, -h, -1, 0));
  }
  for (int i = 0; i < m; ++i)
    for (int j = i + 1; j < m; ++j)
      for (int s = 0; s < 4; ++s) sets.push_back(shifted(i, (s & 1) ? -h : h, j, (s & 2) ? -h : h));
  return sets;
}

// The Hessian of E in the log coordinates from the stencil's values, which start at e[k].
Eigen::MatrixXd HessianOf(const std::vector<double>& e, size_t k, int m, double e_mm, double h) {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < m; ++i, k += 2) H(i, i) = (e[k] - 2 * e_mm + e[k + 1]) / (h * h);
  for (int i = 0; i < m; ++i)
    for (int j = i + 1; j < m; ++j, k += 4) H(i, j) = H(j, i) = (e[k] - e[k + 1] - e[k + 2] + e[k + 3]) / (4 * h * h);
  return H;
}

// The sensitivity of each combination: the change that raises E by 1 % of E, but never
// by less than what tracking resolves (a 1 % rise of a near-zero E would claim a
// precision no data have).
void SetTolerances(const Eigen::MatrixXd& H, const IdentifiabilityOptions& opt, double body_length,
                   IdentifiabilityReport* r) {
  const int m = static_cast<int>(r->log_coordinates.size());
  const auto a = r->estimate.AsArray();
  auto dir = [&](std::array<double, 4> full) {  // a combination's direction in log coordinates
    Eigen::VectorXd u(m);
    for (int i = 0; i < m; ++i) u[i] = full[r->log_coordinates[i]];
    return u;
  };
  auto has = [&](int i) { return a[i] > 0; };
  const double rise_mm = std::max(opt.tolerance_rise * r->e_mm, opt.resolvable_bl * body_length);
  r->K_mu_tolerance = has(0) && has(1) ? Tolerance(H, dir({1, -1, 0, 0}), rise_mm) : kInf;
  r->K_eta_tolerance = has(2) && has(3) ? Tolerance(H, dir({0, 0, 1, -1}), rise_mm) : kInf;
  r->v_c_tolerance = has(1) && has(3) ? Tolerance(H, dir({0, 1, 0, -1}), rise_mm) : kInf;
  r->scale_tolerance = m > 0 ? Tolerance(H, dir({1, 1, 1, 1}), rise_mm) : kInf;
}

std::string Percent(double t) {
  if (std::isinf(t)) return "none (E is flat along it)";
  char b[48];
  std::snprintf(b, sizeof b, "%.2g %%", 100 * t);
  return b;
}

std::string Ratio(const char* name, double v, const char* num, const char* den, const char* unit) {
  char b[120];
  if (std::isnan(v))
    std::snprintf(b, sizeof b, "%s undefined (%s = %s = 0)", name, num, den);
  else if (std::isinf(v))
    std::snprintf(b, sizeof b, "%s infinite (%s = 0)", name, den);
  else
    std::snprintf(b, sizeof b, "%s = %.4g%s", name, v, unit);
  return b;
}

std::string PlainLanguage(const IdentifiabilityReport& r) {
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "At the fit %s, %s, %s. Sensitivity of E, not an uncertainty (the change that raises E by 1 %% "
                "or by what tracking resolves): K_mu %s, K_eta %s, v_c %s. ",
                Ratio("K_mu", r.K_mu, "mu_n", "mu_t", "").c_str(),
                Ratio("K_eta", r.K_eta, "eta_n", "eta_t", "").c_str(),
                Ratio("v_c", r.v_c, "mu_t", "eta_t", " mm/s").c_str(), Percent(r.K_mu_tolerance).c_str(),
                Percent(r.K_eta_tolerance).c_str(), Percent(r.v_c_tolerance).c_str());
  std::string line = buf;
  if (r.scale_determined)
    std::snprintf(buf, sizeof buf,
                  "E depends on the overall scale of the four coefficients only through inertia: it rises by "
                  "%.2g %% of body length between x0.25 and x4.",
                  100 * r.scale_profile_rise_bl);
  else
    std::snprintf(buf, sizeof buf,
                  "The overall scale of the four coefficients is NOT determined: E changes by at most %.2g %% of "
                  "body length between x0.25 and x4, below what tracking resolves, so absolute forces are known "
                  "only up to that scale.",
                  100 * r.scale_profile_rise_bl);
  line += buf;
  if (!r.at_bound.empty()) {
    line += " Estimated as exactly 0:";
    for (const auto& n : r.at_bound) line += " " + n;
    line += ".";
  }
  return line;
}

}  // namespace

Result<IdentifiabilityReport> AnalyseIdentifiability(BatchEvaluator& evaluator, const Coefficients& c, double e_mm,
                                                     double body_length, const IdentifiabilityOptions& opt) {
  IdentifiabilityReport r;
  r.estimate = c;
  r.e_mm = e_mm;
  r.e_percent = 100 * e_mm / body_length;
  r.K_mu = c.K_mu();
  r.K_eta = c.K_eta();
  r.v_c = c.v_c();
  const auto a = c.AsArray();
  for (int i = 0; i < 4; ++i)
    if (a[i] > 0)
      r.log_coordinates.push_back(i);
    else
      r.at_bound.push_back(kNames[i]);
  const int m = static_cast<int>(r.log_coordinates.size());

  std::vector<double> e;
  EvaluationRequest req;
  req.phase = 0;
  req.reuse = false;
  WORMDRAG_RETURN_IF_ERROR(evaluator.Evaluate(ProfileAndStencil(c, r.log_coordinates, opt), &e, req));
  for (size_t k = 0; k < opt.scale_factors.size(); ++k) {
    r.scale_profile.emplace_back(opt.scale_factors[k], e[k]);
    r.scale_profile_rise = std::max(r.scale_profile_rise, e[k] / e_mm - 1);
    r.scale_profile_rise_bl = std::max(r.scale_profile_rise_bl, (e[k] - e_mm) / body_length);
  }
  r.scale_determined = r.scale_profile_rise_bl >= opt.resolvable_bl;
  const Eigen::MatrixXd H = HessianOf(e, opt.scale_factors.size(), m, e_mm, opt.log_step);
  r.hessian.assign(m, std::vector<double>(m));
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) r.hessian[i][j] = H(i, j);
  if (m > 0 && H.allFinite()) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(H);
    for (int i = 0; i < m; ++i) {
      r.eigenvalues.push_back(es.eigenvalues()[i]);
      r.eigenvectors.emplace_back(es.eigenvectors().col(i).data(), es.eigenvectors().col(i).data() + m);
    }
  }
  SetTolerances(H, opt, body_length, &r);
  r.plain_language = PlainLanguage(r);
  return r;
}

Json IdentifiabilityReport::ToJson() const {
  auto rows = [](const std::vector<std::vector<double>>& m) {
    Json a = Json::array();
    for (const auto& row : m) {
      Json r = Json::array();
      for (double v : row) r.push_back(NumberOrInf(v));
      a.push_back(std::move(r));
    }
    return a;
  };
  Json profile = Json::array();
  for (const auto& [factor, e] : scale_profile) profile.push_back(Json::array({NumberOrInf(factor), NumberOrInf(e)}));
  Json coordinates = Json::array();
  for (int i : log_coordinates) coordinates.push_back(kNames[i]);
  Json eigen = Json::array();
  for (double v : eigenvalues) eigen.push_back(NumberOrInf(v));
  return {{"estimate",
           {{"mu_n", NumberOrInf(estimate.mu_n)},
            {"mu_t", NumberOrInf(estimate.mu_t)},
            {"eta_n", NumberOrInf(estimate.eta_n)},
            {"eta_t", NumberOrInf(estimate.eta_t)}}},
          {"E_mm", NumberOrInf(e_mm)},
          {"E_percent_BL", NumberOrInf(e_percent)},
          {"K_mu", NumberOrInf(K_mu)},
          {"K_eta", NumberOrInf(K_eta)},
          {"v_c", NumberOrInf(v_c)},
          {"tolerance",
           {{"K_mu", NumberOrInf(K_mu_tolerance)},
            {"K_eta", NumberOrInf(K_eta_tolerance)},
            {"v_c", NumberOrInf(v_c_tolerance)},
            {"scale", NumberOrInf(scale_tolerance)}}},
          {"scale_profile", profile},
          {"log_coordinates", coordinates},
          {"hessian_log", rows(hessian)},
          {"eigenvalues", eigen},
          {"eigenvectors", rows(eigenvectors)},
          {"at_bound", at_bound},
          {"summary", plain_language}};
}

std::string IdentifiabilityReport::ToText() const {
  std::string s;
  char buf[300];
  std::snprintf(buf, sizeof buf, "  E = %.6g mm = %.4g %% of body length\n", e_mm, e_percent);
  s += buf;
  std::snprintf(buf, sizeof buf, "  K_mu = %.6g   K_eta = %.6g   v_c = %.6g mm/s\n", K_mu, K_eta, v_c);
  s += buf;
  s += "  E along the scale ray (factor: E mm):";
  for (const auto& [f, e] : scale_profile) {
    std::snprintf(buf, sizeof buf, " %.3g:%.6g", f, e);
    s += buf;
  }
  s += "\n  Hessian of E in log-coefficients, eigenvalues (mm):";
  for (double v : eigenvalues) {
    std::snprintf(buf, sizeof buf, " %.3g", v);
    s += buf;
  }
  s += "\n";
  for (size_t i = 0; i < eigenvectors.size(); ++i) {
    s += "    direction " + std::to_string(i + 1) + ":";
    for (size_t j = 0; j < eigenvectors[i].size(); ++j) {
      std::snprintf(buf, sizeof buf, " %+.3f %s", eigenvectors[i][j], kNames[log_coordinates[j]]);
      s += buf;
    }
    s += "\n";
  }
  s += "  " + plain_language + "\n";
  return s;
}

}  // namespace wormdrag
