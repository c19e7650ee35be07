// Prints evaluated coefficient sets (text, csv or json): `wormdrag results` on the
// embedded store and on a server print the same way.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "client/cli.h"
#include "core/store/job_store.h"

namespace wormdrag::cli {

// A job ID from the positionals (a positive number).
Result<int64_t> ParseJobId(const std::vector<std::string>& positionals, size_t index);

// What `wormdrag results` was asked for, validated.
struct ResultsQuery {
  int64_t job = 0;
  int64_t top = 20;        // 0 = all
  int phase = 0;           // 0 = all phases
  bool survivors = false;  // the d1/d2 survivors of `phase` instead of every set
  std::string format = "text";
};
std::vector<Option> ResultsOptionSpecs();
Result<ResultsQuery> ParseResultsQuery(const Args& args);

// A best E in mm for listings: "0.01234", or "-" when there is none yet.
std::string FormatE(double e);

void PrintResults(int64_t job, const std::vector<EvaluationRecord>& rows, const std::string& format);

}  // namespace wormdrag::cli
