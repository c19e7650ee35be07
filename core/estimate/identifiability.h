// What the data determine about the coefficients (docs/conventions.md §2): without inertia only
// K_μ = μ_n/μ_t, K_η = η_n/η_t and v_c = μ_t/η_t are identifiable; the absolute scale
// rests on inertia alone. Reported with every estimate, never hidden.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/common/json.h"
#include "core/common/status.h"
#include "core/estimate/paired_path.h"
#include "core/model/friction_law.h"

namespace wormdrag {

struct IdentifiabilityOptions {
  std::vector<double> scale_factors = {0.25, 0.354, 0.5, 0.707, 1.0, 1.414, 2.0, 2.828, 4.0};
  double log_step = 0.02;  // finite-difference step in log-coefficients
  // Sensitivity (not an uncertainty): the change that raises E by 1 % of E, or by resolvable_bl
  // (in body lengths) if that is more.
  double tolerance_rise = 0.01;
  // A combination whose whole profile moves E by less than this (in body lengths)
  // is "not determined": no tracker resolves it.
  double resolvable_bl = 1e-4;
};

struct IdentifiabilityReport {
  Coefficients estimate;
  double e_mm = 0, e_percent = 0;
  double K_mu = 0, K_eta = 0, v_c = 0;
  std::vector<std::pair<double, double>> scale_profile;  // (factor, E mm)
  double scale_profile_rise = 0;                         // max E over the profile / E at the estimate − 1
  double scale_profile_rise_bl = 0;                      // the same rise in body lengths (absolute)
  bool scale_determined = false;                         // rise_bl ≥ resolvable_bl
  // Hessian of E (mm) in log-coefficients, over the coefficients not at zero.
  std::vector<int> log_coordinates;  // indices (0 μ_n, 1 μ_t, 2 η_n, 3 η_t) in the Hessian
  std::vector<std::vector<double>> hessian;
  std::vector<double> eigenvalues;                // ascending
  std::vector<std::vector<double>> eigenvectors;  // eigenvectors[i] belongs to eigenvalues[i]
  // Relative change of each combination that raises E by max(1 % of E, resolvable_bl)
  // (∞ = not determined).
  double K_mu_tolerance = 0, K_eta_tolerance = 0, v_c_tolerance = 0, scale_tolerance = 0;
  std::vector<std::string> at_bound;  // coefficients estimated as exactly 0
  std::string plain_language;
  Json ToJson() const;  // ±inf as "inf" / "-inf", NaN as null (NumberOrInf)
  std::string ToText() const;
};

Result<IdentifiabilityReport> AnalyseIdentifiability(BatchEvaluator& evaluator, const Coefficients& estimate,
                                                     double e_mm, double body_length,
                                                     const IdentifiabilityOptions& opt = {});

}  // namespace wormdrag
