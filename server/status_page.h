// The coordinator's status page: one self-contained, server-rendered HTML document
// (inline CSS, no scripts, fonts or other network resources; it refreshes itself every
// few seconds) with running and past jobs, phase progress, workers and quarantined
// tasks. Every string that comes from the store or from a worker is escaped.
#pragma once

#include <string>
#include <string_view>

#include "server/status_snapshot.h"

namespace wormdrag::server {

// Seconds between the page's own reloads. Default: 5 s, about as often as a phase's
// progress visibly moves, and cheap for the coordinator.
inline constexpr int kStatusRefreshSeconds = 5;

// `token`: the token the page was opened with in its query (?token=), carried into its
// links; "" when it came in a header or none is needed.
std::string RenderStatusPage(const StatusSnapshot& s, const std::string& token);

// Percent-encodes everything but RFC 3986's unreserved characters (for a query value).
std::string UrlEncode(std::string_view s);

}  // namespace wormdrag::server
