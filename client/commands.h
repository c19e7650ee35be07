// Entry points of the wormdrag subcommands; each returns the process exit code.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "client/cli.h"
#include "core/diagnose/diagnosis.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::cli {

int RunSimulate(const std::vector<std::string>& cmdline);
int RunGenerate(const std::vector<std::string>& cmdline);

// Estimation in this process and the job store (client/cmd_estimate.cc, cmd_jobs.cc, cmd_verify.cc).
int RunEstimate(const std::vector<std::string>& cmdline);
int RunJobs(const std::vector<std::string>& cmdline);
int RunResults(const std::vector<std::string>& cmdline);
int RunVerify(const std::vector<std::string>& cmdline);

// Video analysis and import (client/cmd_track.cc, client/cmd_import.cc).
int RunTrack(const std::vector<std::string>& cmdline);
int RunImport(const std::vector<std::string>& cmdline);
int RunExport(const std::vector<std::string>& cmdline);

// The service (client/cmd_remote.cc): against a wormdrag-server when --server or
// $WORMDRAG_SERVER is given (and no --db), else the embedded job store.
int RunSubmit(const std::vector<std::string>& cmdline);
int RunWatch(const std::vector<std::string>& cmdline);
int RunCancel(const std::vector<std::string>& cmdline);
// Remote `jobs list|show` and `results`: RunJobs/RunResults call these when WantsServer().
int RunJobsRemote(const std::vector<std::string>& cmdline);
int RunResultsRemote(const std::vector<std::string>& cmdline);
bool WantsServer(const std::vector<std::string>& cmdline);
// --server, --token, --tls-*, --db; and a diagnosis job on the server (`diagnose --server`).
std::vector<Option> RemoteOptionSpecs();
int SubmitDiagnosisRemote(const Args& args, const std::array<JobInput, 2>& inputs, const diagnose::DiagnoseOptions& o);

// The sim-to-real gap diagnosis and synthetic recordings (client/cmd_diagnose.cc).
int RunDiagnose(const std::vector<std::string>& cmdline);
int RunSynth(const std::vector<std::string>& cmdline);

// The report and the paper's §4 analyses of stored jobs (client/cmd_report.cc).
int RunReport(const std::vector<std::string>& cmdline);
int RunAnalyze(const std::vector<std::string>& cmdline);

}  // namespace wormdrag::cli
