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

// How the recordings are read: --min-quality.
std::vector<Option> InputOptionSpecs();
// Reads the two recordings named on the command line (their text and file names). With
// --min-quality Q, each K.csv's frames whose quality in K.quality.csv (written by
// `wormdrag track`) is below Q are marked missing first, and stderr says how many.
Result<std::array<JobInput, 2>> ReadJobInputs(const Args& args);

// The job store used without --server: --db, else $WORMDRAG_DB, else ./wormdrag.db.
std::string DefaultDbPath(const Args& args);

}  // namespace wormdrag::cli
