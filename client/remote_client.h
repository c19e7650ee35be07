// The client's side of the job service (client/cmd_remote.cc): the connection flags,
// the channel, RPC errors a user can act on, and following a job to its result.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "client/cli.h"
#include "core/common/status.h"
#include "proto/rpc_util.h"
#include "wormdrag/v2/jobs.grpc.pb.h"

namespace wormdrag::cli::remote {

// `own` followed by the connection flags (RemoteOptionSpecs).
std::vector<Option> With(std::vector<Option> own);
// Whether the command talks to a server: --server, or $WORMDRAG_SERVER without --db.
bool Remote(const Args& a);
// The connection settings; an unreadable or empty --token-file is an error naming it.
Result<rpc::ClientConfig> Config(const Args& a);
Result<std::unique_ptr<v2::JobService::Stub>> Stub(const rpc::ClientConfig& c);
// A failed call as a user reads it: the server's address when it is unreachable (with
// a TLS hint), and which token a refused call needs: a missing or wrong token
// (UNAUTHENTICATED) is told apart from a valid token of the other role
// (PERMISSION_DENIED: the workers' token given to a client command), whose fix is
// another file, not another try.
Status Rpc(const grpc::Status& st, const rpc::ClientConfig& c);
const char* StateName(v2::JobState s);
bool Terminal(v2::JobState s);
// "phase1 [######----] 312/625 sets | tasks 3 queued 2 leased 40 done | 2 workers |
// 820 sets/s ETA 3 s | best E 0.0123 mm"
std::string ProgressLine(const v2::JobProgress& p);
// Follows a job to its end, reopening the stream while the coordinator restarts;
// returns the exit code (0 done, 1 failed or cancelled).
int WatchRemote(v2::JobService::Stub& stub, const rpc::ClientConfig& c, int64_t id, const char* cmd);
// Prints a finished job's result (text, or JSON with `json`); `save_json` non-empty:
// also writes the result JSON to that file.
int PrintResult(v2::JobService::Stub& stub, const rpc::ClientConfig& c, int64_t id, bool json, const char* cmd,
                const std::string& save_json = "");

}  // namespace wormdrag::cli::remote
