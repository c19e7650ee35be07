// Prints evaluated coefficient sets (text, csv or json): `wormdrag results` on the
// embedded store and on a server print the same way.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/store/job_store.h"

namespace wormdrag::cli {

bool IsResultsFormat(const std::string& format);  // text, csv or json
void PrintResults(int64_t job, const std::vector<EvaluationRecord>& rows, const std::string& format);

}  // namespace wormdrag::cli
