// The coordinator's read-only web endpoints (`wormdrag-server --http [HOST:]PORT`):
//   /         the status page (server/status_page.h)
//   /metrics  Prometheus text format (server/metrics_text.h)
// Authentication is the coordinator's client token, as an "Authorization: Bearer T"
// header (curl, Prometheus) or a ?token=T query (a browser's address bar). With the
// coordinator's TLS certificate the endpoints are HTTPS, and with its client CA they
// require a client certificate too. Served by cpp-httplib on two threads.
#pragma once

#include <memory>
#include <string>

#include "core/common/status.h"
#include "server/coordinator.h"

namespace wormdrag::server {

struct StatusHttpOptions {
  // Default: loopback only: the page names recordings and jobs, so exposing it is a
  // decision (`--http 0.0.0.0:8080`), and an SSH tunnel reaches it meanwhile.
  std::string host = "127.0.0.1";
  int port = 0;                                  // 0 = any free port (logged)
  std::string token;                             // "" = no authentication, as for gRPC
  std::string tls_cert, tls_key, tls_client_ca;  // PEM files, as the gRPC server's
  // Ended jobs listed on the page. Default: 50, a screen or two.
  int past_jobs = 50;
};

// "PORT" or "HOST:PORT" ("[v6]:PORT") into options; false with *error set if malformed.
bool ParseHttpAddress(const std::string& text, StatusHttpOptions* o, std::string* error);

// Whether a request carries `token` (constant time); always true when token is "".
bool HttpAuthorized(const std::string& authorization_header, const std::string& query_token, const std::string& token);

class StatusHttpServer {
 public:
  // Binds and starts serving, or says why it cannot (address in use, bad certificate).
  static Result<std::unique_ptr<StatusHttpServer>> Start(Coordinator& c, const StatusHttpOptions& o);
  ~StatusHttpServer();  // stops serving
  int port() const { return port_; }

 private:
  struct Impl;
  explicit StatusHttpServer(std::unique_ptr<Impl> impl, int port);
  std::unique_ptr<Impl> impl_;
  int port_;
};

}  // namespace wormdrag::server
