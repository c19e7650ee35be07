#include "proto/convert.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/jobs/bootstrap_run.h"

namespace wormdrag::rpc {

namespace v2 = wormdrag::v2;

Result<JobOptions> OptionsFromProto(const v2::EstimateOptions& o) {
  nlohmann::json j = nlohmann::json::parse(JobOptions().ToJson());
  auto& ev = j["eval"];
  if (o.points_size() > 0) ev["points"] = std::vector<int>(o.points().begin(), o.points().end());
  auto num = [](double v, const char* name) -> Status {
    if (!std::isfinite(v)) return Status::InvalidArgument(std::string("option ") + name + " must be a finite number");
    return Status::Ok();
  };
#define WD_SET(field, target, key)                                         \
  if (o.has_##field()) {                                                   \
    WORMDRAG_RETURN_IF_ERROR(num(static_cast<double>(o.field()), #field)); \
    target[key] = o.field();                                               \
  }
  WD_SET(t_max, ev, "t_max")
  WD_SET(epsilon, ev, "eps")
  WD_SET(tolerance, ev, "tolerance")
  WD_SET(substeps, ev, "substeps")
  WD_SET(screening_substeps, j, "screening_substeps")
  WD_SET(n_max, j, "n_max")
  WD_SET(d_mu, j, "d_mu")
  WD_SET(d_eta, j, "d_eta")
  WD_SET(d1, j, "d1")
  WD_SET(d2, j, "d2")
  WD_SET(grg_max_iterations, j, "grg_max_iterations")
  WD_SET(grg_gradient_tolerance, j, "grg_gradient_tolerance")
  WD_SET(fd_step, j, "fd_step")
  WD_SET(max_evaluations, j, "max_evaluations")
  WD_SET(lowpass_hz, j, "lowpass_hz")
  WD_SET(bootstrap_replicates, j, "bootstrap_replicates")
  WD_SET(restart_every, ev, "restart_every")
  WD_SET(spline_order, j, "spline_order")
  WD_SET(bootstrap_level, j, "bootstrap_level")
  WD_SET(knot_rate, ev, "knot_rate")
#undef WD_SET
  if (o.has_smoothing()) j["smoothing"] = o.smoothing();
  if (o.has_solver()) ev["solver"] = o.solver();
  if (o.has_restart_after_gaps()) ev["restart_after_gaps"] = o.restart_after_gaps();
  if (o.has_phase3()) j["phase3"] = o.phase3();
  if (o.has_fix_scale()) j["fix_scale"] = o.fix_scale();
  if (o.has_causal_filter()) j["causal_filter"] = o.causal_filter();
  if (o.has_full_grid()) j["abandon"] = !o.full_grid();
  if (o.has_bootstrap_seed()) j["bootstrap_seed"] = o.bootstrap_seed();
  return JobOptionsFromJson(j.dump());
}

void OptionsToProto(const JobOptions& o, wormdrag::v2::EstimateOptions* p) {
  const EstimateOptions& e = o.estimate;
  p->clear_points();
  for (int k : e.eval.points) p->add_points(k);
  p->set_t_max(e.eval.t_max);
  p->set_solver(SolverName(e.eval.sim.solver));
  p->set_epsilon(e.eval.sim.epsilon);
  p->set_tolerance(e.eval.sim.velocity_tolerance);
  p->set_substeps(e.eval.substeps);
  p->set_restart_after_gaps(e.eval.restart_after_gaps);
  p->set_screening_substeps(e.screening_substeps);
  p->set_n_max(e.search.n_max);
  p->set_d_mu(e.search.d_mu);
  p->set_d_eta(e.search.d_eta);
  p->set_d1(e.search.d1);
  p->set_d2(e.search.d2);
  p->set_phase3(Phase3MethodName(e.phase3.method));
  p->set_fix_scale(e.phase3.fix_scale);
  p->set_grg_max_iterations(e.phase3.grg.max_iterations);
  p->set_grg_gradient_tolerance(e.phase3.grg.gradient_tolerance);
  p->set_fd_step(e.phase3.grg.fd_step);
  p->set_max_evaluations(e.phase3.max_evaluations);
  p->set_lowpass_hz(o.lowpass_hz);
  p->set_causal_filter(o.causal_filter);
  p->set_smoothing(SmoothingMethodName(o.smoothing));
  p->set_bootstrap_replicates(o.bootstrap.replicates);
  p->set_restart_every(e.eval.restart_every);
  p->set_full_grid(!e.search.abandon);
  p->set_spline_order(o.spline.order);
  p->set_bootstrap_level(o.bootstrap.level);
  p->set_bootstrap_seed(o.bootstrap.seed);
  p->set_knot_rate(e.eval.knot_rate);
}

// The diagnosis options whose wire field has the member's name and type, read and
// written from this one list so that a field cannot go one way only.
// clang-format off
#define WD_DIAGNOSE_SCALARS(X) \
  X(t_max) X(lowpass_hz) X(interpolate_gaps) X(blocks) X(null_replicates) X(base_grid) X(grg_iterations) \
  X(substeps) X(epsilon) X(seed) X(fit_hz) X(base_iterations) X(simex_draws) X(base_multistart) \
  X(cv_ridge) X(refine_top) X(penalty_per_param) X(min_improvement) X(tie_fraction) \
  X(explained_share) X(false_alarm_rate) X(require_shrink_interval) X(nested_fallback) \
  X(simex_top) X(simex_weight) X(simex_min_keep) X(score_refined_fit) X(require_gap_signature) X(require_estimated_params) \
  X(clear_margin)
// clang-format on

Result<diagnose::DiagnoseOptions> DiagnoseOptionsFromProto(const v2::DiagnoseOptions& p) {
  diagnose::DiagnoseOptions o;
  auto finite = [](double v, const char* name) -> Status {
    if (!std::isfinite(v)) return Status::InvalidArgument(std::string("diagnosis option ") + name + " must be finite");
    return Status::Ok();
  };
#define WD_GET(field)                                                         \
  if (p.has_##field()) {                                                      \
    WORMDRAG_RETURN_IF_ERROR(finite(static_cast<double>(p.field()), #field)); \
    o.field = p.field();                                                      \
  }
  WD_DIAGNOSE_SCALARS(WD_GET)
#undef WD_GET
  if (p.points_size() > 0) o.points.assign(p.points().begin(), p.points().end());
  if (p.has_smoothing()) {
    auto m = ParseSmoothingMethod(p.smoothing());
    if (!m.ok()) return m.status().Annotate("diagnosis option smoothing");
    o.smoothing = *m;
  }
  if (p.has_spline_order()) o.spline.order = p.spline_order();
  if (p.has_noise_sigma()) {
    WORMDRAG_RETURN_IF_ERROR(finite(p.noise_sigma(), "noise_sigma"));
    if (p.noise_sigma() < 0)
      return Status::InvalidArgument("diagnosis option noise_sigma must be >= 0 (unset = estimate)");
    o.noise_sigma = p.noise_sigma();
  }
  o.effects.assign(p.effects().begin(), p.effects().end());
  if (p.start_size() > 0) {
    if (p.start_size() != 4)
      return Status::InvalidArgument("diagnosis option start needs 4 values (mu_n, mu_t, eta_n, eta_t)");
    for (double v : p.start()) WORMDRAG_RETURN_IF_ERROR(finite(v, "start"));
    o.start = {p.start(0), p.start(1), p.start(2), p.start(3)};
  }
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  return o;
}

void DiagnoseOptionsToProto(const diagnose::DiagnoseOptions& o, v2::DiagnoseOptions* p) {
  p->Clear();
#define WD_PUT(field) p->set_##field(o.field);
  WD_DIAGNOSE_SCALARS(WD_PUT)
#undef WD_PUT
  for (int i : o.points) p->add_points(i);
  p->set_smoothing(SmoothingMethodName(o.smoothing));
  p->set_spline_order(o.spline.order);
  if (o.noise_sigma >= 0) p->set_noise_sigma(o.noise_sigma);
  for (const auto& e : o.effects) p->add_effects(e);
  for (double v : o.start.AsArray()) p->add_start(v);
}

#undef WD_DIAGNOSE_SCALARS

namespace {

void CoefficientsToProto(const Coefficients& c, v2::Coefficients* p) {
  p->set_mu_n(c.mu_n);
  p->set_mu_t(c.mu_t);
  p->set_eta_n(c.eta_n);
  p->set_eta_t(c.eta_t);
}
Coefficients CoefficientsFromProto(const v2::Coefficients& p) {
  return {p.mu_n(), p.mu_t(), p.eta_n(), p.eta_t()};
}

}  // namespace

void ReplicateTaskToProto(const ReplicateTask& t, v2::ReplicateTask* p) {
  p->set_index(t.index);
  CoefficientsToProto(t.estimate.set, p->mutable_estimate());
  p->set_estimate_e(t.estimate.e);
  if (t.model) CoefficientsToProto(*t.model, p->mutable_model());
  p->clear_noise_mm();
  for (double v : t.noise_mm) p->add_noise_mm(v);
  p->set_refit_data(t.refit_data);
  p->set_smoothing_scale(t.smoothing_scale);
}

Result<ReplicateTask> ReplicateTaskFromProto(const v2::ReplicateTask& p) {
  if (!p.has_estimate() || p.noise_mm_size() != 2)
    return Status::InvalidArgument("bootstrap task: estimate needs 4 values, noise 2");
  ReplicateTask t;
  t.index = p.index();
  t.estimate = {CoefficientsFromProto(p.estimate()), p.estimate_e()};
  if (p.has_model()) t.model = CoefficientsFromProto(p.model());
  t.noise_mm = {p.noise_mm(0), p.noise_mm(1)};
  t.refit_data = p.refit_data();
  t.smoothing_scale = p.refit_data() ? p.smoothing_scale() : 1.0;
  WORMDRAG_RETURN_IF_ERROR(CheckReplicateTask(t));
  return t;
}

void FitTaskToProto(const diagnose::FitTask& t, v2::FitTask* p) {
  const diagnose::FitSpec& s = t.spec;
  p->Clear();
  p->set_replicate(t.replicate);
  CoefficientsToProto(t.null_base, p->mutable_null_base());
  p->set_null_sigma(t.null_sigma);
  if (s.has_effect) p->set_effect(diagnose::InfoOf(s.effect).name);
  for (const auto& v : s.effect_starts) *p->add_effect_starts()->mutable_values() = {v.begin(), v.end()};
  CoefficientsToProto(s.start, p->mutable_start());
  for (const auto& c : s.extra_starts) CoefficientsToProto(c, p->add_extra_starts());
  CoefficientsToProto(s.prior, p->mutable_prior());
  p->set_prior_weight(s.prior_weight);
  p->set_blocked(s.blocked);
  p->set_train_parity(s.train_parity);
  p->set_iterations(s.iterations);
  p->set_epsilon(s.epsilon);
  p->set_forward_differences(s.forward_differences);
  p->set_per_worm(s.per_worm);
}

Result<diagnose::FitTask> FitTaskFromProto(const v2::FitTask& p) {
  if (!p.has_null_base() || !p.has_start()) return Status::InvalidArgument("fit task: null_base and start are needed");
  diagnose::FitTask t;
  diagnose::FitSpec& s = t.spec;
  t.replicate = p.replicate();
  t.null_base = CoefficientsFromProto(p.null_base());
  t.null_sigma = p.null_sigma();
  s.has_effect = !p.effect().empty();
  if (s.has_effect) {
    auto e = diagnose::ParseEffectName(p.effect());
    if (!e.ok()) return e.status().Annotate("fit task");
    s.effect = *e;
  }
  for (const auto& v : p.effect_starts()) s.effect_starts.emplace_back(v.values().begin(), v.values().end());
  s.start = CoefficientsFromProto(p.start());
  for (const auto& c : p.extra_starts()) s.extra_starts.push_back(CoefficientsFromProto(c));
  if (p.has_prior()) s.prior = CoefficientsFromProto(p.prior());
  s.prior_weight = p.prior_weight();
  s.blocked = p.blocked();
  s.train_parity = p.train_parity();
  s.iterations = p.iterations();
  s.epsilon = p.epsilon();
  s.forward_differences = p.forward_differences();
  s.per_worm = p.per_worm();
  WORMDRAG_RETURN_IF_ERROR(CheckFitTask(t));
  return t;
}

}  // namespace wormdrag::rpc
