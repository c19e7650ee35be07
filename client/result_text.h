// A finished job's result for the user, embedded or from the service: both read the
// typed messages GetResults carries (proto/wormdrag/v2/results.proto).
#pragma once

#include <string>

#include "core/common/status.h"
#include "wormdrag/v2/jobs.pb.h"

namespace wormdrag::cli {

// The summary an estimate or a diagnosis prints.
std::string EstimateResultText(const wormdrag::v2::EstimateResult& r);
std::string DiagnosisResultText(const wormdrag::v2::DiagnosisResult& r);
// Whichever result `r` holds, as text or as JSON ("{}" if none).
std::string ResultText(const wormdrag::v2::GetResultsResponse& r);
std::string ResultJson(const wormdrag::v2::GetResultsResponse& r);

// A stored job's result document as GetResults would carry it.
Result<wormdrag::v2::GetResultsResponse> TypedResult(const std::string& kind, const std::string& document);

}  // namespace wormdrag::cli
