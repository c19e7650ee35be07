#include "proto/convert.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace wormdrag::rpc {

namespace v1 = wormdrag::v1;

Result<JobOptions> OptionsFromProto(const v1::EstimateOptions& o) {
  nlohmann::json j = nlohmann::json::parse(JobOptions().ToJson());
  auto& ev = j["eval"];
  if (o.points_size() > 0) ev["points"] = std::vector<int>(o.points().begin(), o.points().end());
  auto num = [](double v, const char* name) -> Status {
    if (!std::isfinite(v)) return Status::InvalidArgument(std::string("option ") + name + " must be a finite number");
    return Status::Ok();
  };
#define WD_SET(field, target, key)                                   \
  if (o.has_##field()) {                                             \
    WORMDRAG_RETURN_IF_ERROR(num(static_cast<double>(o.field()), #field)); \
    target[key] = o.field();                                         \
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
#undef WD_SET
  if (o.has_solver()) ev["solver"] = o.solver();
  if (o.has_restart_after_gaps()) ev["restart_after_gaps"] = o.restart_after_gaps();
  if (o.has_phase3()) j["phase3"] = o.phase3();
  if (o.has_fix_scale()) j["fix_scale"] = o.fix_scale();
  if (o.has_causal_filter()) j["causal_filter"] = o.causal_filter();
  return JobOptionsFromJson(j.dump());
}

}  // namespace wormdrag::rpc

namespace wormdrag::rpc {

void OptionsToProto(const JobOptions& o, wormdrag::v1::EstimateOptions* p) {
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
}

}  // namespace wormdrag::rpc
