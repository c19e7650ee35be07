// Conversions between the wire options and core's JobOptions, shared by the
// coordinator (validating a submission, sending a job's options), the worker (reading
// a task's options) and the CLI (embedded runs of the same flags).
#pragma once

#include "core/jobs/diagnose_job.h"
#include "core/jobs/estimate_job.h"
#include "wormdrag/v2/jobs.pb.h"
#include "wormdrag/v2/worker.pb.h"

namespace wormdrag::rpc {

// Unset fields keep the defaults of JobOptions; the result is validated by core
// (INVALID_ARGUMENT naming the bad option).
Result<JobOptions> OptionsFromProto(const wormdrag::v2::EstimateOptions& o);
// Every field set, so the server rebuilds exactly these options.
void OptionsToProto(const JobOptions& o, wormdrag::v2::EstimateOptions* p);

// The same for diagnosis jobs (unset fields: DiagnoseOptions' defaults; validated).
Result<diagnose::DiagnoseOptions> DiagnoseOptionsFromProto(const wormdrag::v2::DiagnoseOptions& o);
void DiagnoseOptionsToProto(const diagnose::DiagnoseOptions& o, wormdrag::v2::DiagnoseOptions* p);

// A bootstrap refit on the wire; FromProto refuses what CheckReplicateTask refuses.
void ReplicateTaskToProto(const ReplicateTask& t, wormdrag::v2::ReplicateTask* p);
Result<ReplicateTask> ReplicateTaskFromProto(const wormdrag::v2::ReplicateTask& p);

// A diagnosis fit on the wire; FromProto refuses what CheckFitTask refuses.
void FitTaskToProto(const diagnose::FitTask& t, wormdrag::v2::FitTask* p);
Result<diagnose::FitTask> FitTaskFromProto(const wormdrag::v2::FitTask& p);

// A job's options on the wire (the `options` of v2::Job or v2::Task) from the canonical
// text the store keeps, every field set. Stored text of any form JobOptionsFromJson or
// DiagnoseOptionsFromJson reads gives options that run identically.
template <typename WithOptions>
Status SetJobOptions(const std::string& stored_text, bool diagnosis, WithOptions* m) {
  if (diagnosis) {
    auto o = DiagnoseOptionsFromJson(stored_text);
    if (!o.ok()) return o.status();
    DiagnoseOptionsToProto(*o, m->mutable_diagnose_options());
    return Status::Ok();
  }
  auto o = JobOptionsFromJson(stored_text);
  if (!o.ok()) return o.status();
  OptionsToProto(*o, m->mutable_estimate_options());
  return Status::Ok();
}

// The canonical text of a job's options on the wire, as SetJobOptions was given it
// (for a job stored in an older form: the same options in today's form).
template <typename WithOptions>
Result<std::string> JobOptionsText(const WithOptions& m) {
  if (m.has_diagnose_options()) {
    auto o = DiagnoseOptionsFromProto(m.diagnose_options());
    if (!o.ok()) return o.status();
    return DiagnoseOptionsToJson(*o);
  }
  if (!m.has_estimate_options()) return Status::InvalidArgument("no job options");
  auto o = OptionsFromProto(m.estimate_options());
  if (!o.ok()) return o.status();
  return o->ToJson();
}

}  // namespace wormdrag::rpc
