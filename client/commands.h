// Entry points of the wormdrag subcommands; each returns the process exit code.
#pragma once

#include <array>
#include <vector>

#include "client/args.h"
#include "core/diagnose/diagnosis.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::cli {

int RunSimulate(int argc, char** argv);
int RunGenerate(int argc, char** argv);

// Estimation in this process and the job store (client/cmd_estimate.cc, cmd_jobs.cc, cmd_verify.cc).
int RunEstimate(int argc, char** argv);
int RunJobs(int argc, char** argv);
int RunResults(int argc, char** argv);
int RunVerify(int argc, char** argv);

// Video analysis and import (client/cmd_track.cc, client/cmd_import.cc).
int RunTrack(int argc, char** argv);
int RunImport(int argc, char** argv);
int RunExport(int argc, char** argv);

// The service (client/cmd_remote.cc): against a wormdrag-server when --server or
// $WORMDRAG_SERVER is given (and no --db), else the embedded job store.
int RunSubmit(int argc, char** argv);
int RunWatch(int argc, char** argv);
int RunCancel(int argc, char** argv);
// Remote `jobs list|show` and `results`: RunJobs/RunResults call these when WantsServer().
int RunJobsRemote(int argc, char** argv);
int RunResultsRemote(int argc, char** argv);
bool WantsServer(int argc, char** argv);
// --server, --token, --tls-*, --db; and a diagnosis job on the server (`diagnose --server`).
std::vector<OptionSpec> RemoteOptionSpecs();
int SubmitDiagnosisRemote(const Args& args, const std::array<JobInput, 2>& inputs, const diagnose::DiagnoseOptions& o);

// The sim-to-real gap diagnosis and synthetic recordings (client/cmd_diagnose.cc).
int RunDiagnose(int argc, char** argv);
int RunSynth(int argc, char** argv);

// The report and the paper's §4 analyses of stored jobs (client/cmd_report.cc).
int RunReport(int argc, char** argv);
int RunAnalyze(int argc, char** argv);

}  // namespace wormdrag::cli
