// Entry points of the wormdrag subcommands; each returns the process exit code.
#pragma once

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

// The sim-to-real gap diagnosis and synthetic recordings (client/cmd_diagnose.cc).
int RunDiagnose(int argc, char** argv);
int RunSynth(int argc, char** argv);

}  // namespace wormdrag::cli
