#include "server/status_http.h"

#include <thread>

#include <httplib.h>
#include <spdlog/spdlog.h>

#include "server/metrics_text.h"
#include "server/status_page.h"
#include "server/status_snapshot.h"

namespace wormdrag::server {

namespace {

bool ConstantTimeEquals(const std::string& got, const std::string& want) {
  unsigned diff = got.size() == want.size() ? 0u : 1u;
  for (size_t i = 0; i < got.size() && i < want.size(); ++i) diff |= static_cast<unsigned>(got[i] ^ want[i]);
  return diff == 0;
}

// The page loads nothing: no scripts, fonts, images or frames; inline CSS only.
constexpr const char* kPagePolicy =
    "default-src 'none'; style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

}  // namespace

bool ParseHttpAddress(const std::string& text, StatusHttpOptions* o, std::string* error) {
  std::string host = o->host, port = text;
  if (auto colon = text.rfind(':'); colon != std::string::npos) {
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  }
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 0 || p > 65535 || host.empty()) {
    *error = "--http takes PORT or HOST:PORT (port 0-65535), got '" + text + "'";
    return false;
  }
  o->host = host;
  o->port = static_cast<int>(p);
  return true;
}

bool HttpAuthorized(const std::string& authorization_header, const std::string& query_token, const std::string& token) {
  if (token.empty()) return true;
  // Both are compared, so the time taken does not say which one was tried.
  const bool header = ConstantTimeEquals(authorization_header, "Bearer " + token);
  const bool query = ConstantTimeEquals(query_token, token);
  return header || query;
}

struct StatusHttpServer::Impl {
  std::unique_ptr<httplib::Server> server;
  std::thread thread;
};

StatusHttpServer::StatusHttpServer(std::unique_ptr<Impl> impl, int port) : impl_(std::move(impl)), port_(port) {}

StatusHttpServer::~StatusHttpServer() {
  impl_->server->stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

Result<std::unique_ptr<StatusHttpServer>> StatusHttpServer::Start(Coordinator& c, const StatusHttpOptions& o) {
  auto impl = std::make_unique<Impl>();
  if (!o.tls_cert.empty()) {
    impl->server = std::make_unique<httplib::SSLServer>(o.tls_cert.c_str(), o.tls_key.c_str(),
                                                        o.tls_client_ca.empty() ? nullptr : o.tls_client_ca.c_str());
  } else {
    impl->server = std::make_unique<httplib::Server>();
  }
  httplib::Server& svr = *impl->server;
  if (!svr.is_valid()) return Status::InvalidArgument("--http: cannot use the TLS certificate/key for HTTPS");
  svr.new_task_queue = [] { return new httplib::ThreadPool(2); };
  svr.set_default_headers(
      {{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}, {"Referrer-Policy", "no-referrer"}});
  const std::string token = o.token;
  const int past = o.past_jobs;
  // Answers an authorised request from a fresh snapshot: the page or the metrics.
  auto serve = [&c, token, past](const httplib::Request& req, httplib::Response& res, bool page) {
    const std::string query_token = req.get_param_value("token");
    if (!HttpAuthorized(req.get_header_value("Authorization"), query_token, token)) {
      res.status = 401;
      res.set_header("WWW-Authenticate", "Bearer realm=\"wormdrag\"");
      res.set_content("this coordinator needs its token: an \"Authorization: Bearer TOKEN\" header or ?token=TOKEN\n",
                      "text/plain; charset=utf-8");
      return;
    }
    auto snapshot = CollectStatus(c, past);
    if (!snapshot.ok()) {
      res.status = 500;
      res.set_content(snapshot.status().ToString() + "\n", "text/plain; charset=utf-8");
      return;
    }
    if (page) {
      res.set_header("Content-Security-Policy", kPagePolicy);
      res.set_content(RenderStatusPage(*snapshot, token.empty() ? "" : query_token), "text/html; charset=utf-8");
    } else {
      res.set_content(RenderMetrics(*snapshot), kMetricsContentType);
    }
  };
  svr.Get("/", [serve](const httplib::Request& req, httplib::Response& res) { serve(req, res, true); });
  svr.Get("/metrics", [serve](const httplib::Request& req, httplib::Response& res) { serve(req, res, false); });
  svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
    res.status = 500;
    res.set_content("internal error\n", "text/plain; charset=utf-8");
  });

  int port = o.port;
  if (port == 0) {
    port = svr.bind_to_any_port(o.host);
    if (port < 0) port = 0;
  } else if (!svr.bind_to_port(o.host, port)) {
    port = 0;
  }
  if (port == 0) return Status::Unavailable("--http: cannot listen on " + o.host + ":" + std::to_string(o.port));
  httplib::Server* raw = impl->server.get();
  impl->thread = std::thread([raw] { raw->listen_after_bind(); });
  spdlog::info("event=http_listening address={} port={} tls={} auth={}", o.host, port, !o.tls_cert.empty(),
               !token.empty());
  return std::unique_ptr<StatusHttpServer>(new StatusHttpServer(std::move(impl), port));
}

}  // namespace wormdrag::server
