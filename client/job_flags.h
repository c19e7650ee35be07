// The estimation options as command-line flags, shared by `wormdrag estimate`
// (embedded) and `wormdrag submit` (service): one list, one parser, one --help text.
#pragma once

#include <string>
#include <vector>

#include "client/cli.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::cli {

// Every option of a job (docs/conventions.md §3 defaults), for Usage() and Args::Parse().
std::vector<Option> JobOptionSpecs();
// Builds and validates the options from parsed flags.
Result<JobOptions> JobOptionsFromArgs(const Args& args);

// Reads the two recordings named on the command line (their text and file names).
Result<std::array<JobInput, 2>> ReadJobInputs(const std::vector<std::string>& paths);

// The job store used without --server: --db, else $WORMDRAG_DB, else ./wormdrag.db.
std::string DefaultDbPath(const Args& args);

}  // namespace wormdrag::cli
