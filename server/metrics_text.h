// /metrics of the coordinator in the Prometheus text exposition format (version 0.0.4):
// jobs by state, workers, tasks leased/expired/quarantined, sets simulated and per
// second, and the latency of the task store's SQLite group commits.
#pragma once

#include <string>

#include "server/status_snapshot.h"

namespace wormdrag::server {

inline constexpr const char* kMetricsContentType = "text/plain; version=0.0.4; charset=utf-8";

std::string RenderMetrics(const StatusSnapshot& s);

// A label value with \, " and newline escaped, as the format requires.
std::string EscapeLabelValue(const std::string& v);

}  // namespace wormdrag::server
