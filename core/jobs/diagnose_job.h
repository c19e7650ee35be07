// Diagnosis jobs on the job store (kind "diagnose"): what the coordinator runs with
// workers, and the wire form of their pieces. The science stays in core/diagnose; this
// layer stores the job and its result and (de)serialises options and fit tasks.
//
// The coordinator runs the base fit and the cheap parts itself and hands every effect,
// null and refit fit (the bulk: (1 + null replicates) × 18 fits of ~200 simulations) to
// workers as tasks: a task's payload is FitTaskToJson, its result FitOutcomeToValues.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/options.h"
#include "core/jobs/estimate_job.h"
#include "core/store/job_store.h"

namespace wormdrag {

// Canonical JSON of every option that changes the diagnosis (not threads or hooks).
std::string DiagnoseOptionsToJson(const diagnose::DiagnoseOptions& o);
// Missing keys take their defaults; the result is validated.
Result<diagnose::DiagnoseOptions> DiagnoseOptionsFromJson(const std::string& json);

// A fit as the coordinator keeps it (and makes the task's id from; workers get it
// typed, proto/convert.h).
std::string FitTaskToJson(const diagnose::FitTask& t);
Result<diagnose::FitTask> FitTaskFromJson(const std::string& json);
// InvalidArgument unless a fit a worker was sent is one it can run: effect starts of the
// effect's size, parity, iterations, eps and prior weight in range (FitTaskFromJson
// checks it too).
Status CheckFitTask(const diagnose::FitTask& t);
// A fit outcome as numbers: 4 coefficients, training MSE, evaluations, effect parameters.
std::vector<double> FitOutcomeToValues(const diagnose::FitOutcome& f);
Result<diagnose::FitOutcome> FitOutcomeFromValues(const std::vector<double>& v, const diagnose::FitTask& task);

// Parses both recordings and checks that the diagnosis can prepare them; stores the
// job (queued) only then.
Result<int64_t> SubmitDiagnoseJob(JobStore& store, const std::array<JobInput, 2>& inputs,
                                  const diagnose::DiagnoseOptions& options);
// The recordings of a stored job, parsed.
Result<std::array<Kinematics, 2>> LoadRecordings(JobStore& store, const JobRecord& job);

// Runs a queued or interrupted diagnosis job to the end (result: Diagnosis::ToJson).
// `run_fits` empty: local threads. Progress: stage, fits done, fits total.
Status RunDiagnoseJob(JobStore& store, int64_t job_id, const diagnose::FitRunner& run_fits, int threads,
                      const JobHooks& hooks = {});

}  // namespace wormdrag
