// Wire helpers shared by the coordinator, the worker and the CLI: channels (plain,
// TLS, mutual TLS), the bearer token, deadlines, and Status <-> grpc::Status.
// Core code never includes this header (nor any generated *.pb.h).
#pragma once

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "core/common/status.h"

namespace wormdrag::rpc {

// How a client (CLI or worker) reaches the coordinator.
struct ClientConfig {
  std::string server;       // HOST:PORT
  std::string token;        // "" = none; sent as "authorization: Bearer <token>"
  std::string tls_ca;       // PEM file of the CA that signed the server; "" = plaintext
  std::string tls_cert;     // client certificate (mutual TLS), PEM file
  std::string tls_key;      // its private key, PEM file
  int max_message_mb = 64;  // largest message received
};

// The channel, or why it cannot be made (unreadable certificate files …).
Result<std::shared_ptr<grpc::Channel>> MakeChannel(const ClientConfig& config);

// Sets the token and a deadline `seconds` from now on a client call.
void Prepare(grpc::ClientContext* ctx, const std::string& token, double seconds);

// Server side: OK when no token is configured or the call carries it.
grpc::Status CheckToken(const grpc::ServerContext* ctx, const std::string& token);

// The project's codes are the gRPC codes (core/common/status.h).
grpc::Status ToGrpc(const Status& st);
Status FromGrpc(const grpc::Status& st);

// Reads a whole file (PEM, token file …).
Result<std::string> ReadText(const std::string& path);

// Environment fallbacks of the CLI and the worker.
inline constexpr const char* kServerEnv = "WORMDRAG_SERVER";
inline constexpr const char* kTokenEnv = "WORMDRAG_TOKEN";
std::string EnvOr(const char* name, const std::string& fallback);

// A bearer token: the contents of `file` (surrounding whitespace trimmed) when given,
// else `flag`, else $WORMDRAG_TOKEN, else "". A file keeps the token off the command
// line, where `ps` shows it to every user of the machine. An empty or unreadable
// file is an error naming it.
Result<std::string> ResolveToken(const std::string& file, const std::string& flag);

// Whether HOST:PORT (or [v6]:PORT) names a loopback address only.
bool IsLoopbackAddress(const std::string& host_port);

}  // namespace wormdrag::rpc
