// Conversions between the wire options and core's JobOptions, shared by the
// coordinator (validating a submission) and the CLI (embedded runs of the same flags).
#pragma once

#include "core/jobs/diagnose_job.h"
#include "core/jobs/estimate_job.h"
#include "wormdrag/v1/jobs.pb.h"

namespace wormdrag::rpc {

// Unset fields keep the defaults of JobOptions; the result is validated by core
// (INVALID_ARGUMENT naming the bad option).
Result<JobOptions> OptionsFromProto(const wormdrag::v1::EstimateOptions& o);
// Every field set, so the server rebuilds exactly these options.
void OptionsToProto(const JobOptions& o, wormdrag::v1::EstimateOptions* p);

// The same for diagnosis jobs (unset fields: DiagnoseOptions' defaults; validated).
Result<diagnose::DiagnoseOptions> DiagnoseOptionsFromProto(const wormdrag::v1::DiagnoseOptions& o);
void DiagnoseOptionsToProto(const diagnose::DiagnoseOptions& o, wormdrag::v1::DiagnoseOptions* p);

}  // namespace wormdrag::rpc
