#include "client/remote_client.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include "client/commands.h"
#include "client/progress.h"
#include "client/result_text.h"
#include "client/results_table.h"
#include "core/store/job_store.h"

namespace wormdrag::cli {

namespace {

const std::vector<Option> kRemoteSpecs = {
    {"server", "HOST:PORT", "coordinator (also $WORMDRAG_SERVER); without it, the embedded job store", ""},
    {"token", "T", "bearer token; visible in `ps`: prefer --token-file or $WORMDRAG_TOKEN", "$WORMDRAG_TOKEN"},
    {"token-file", "FILE", "read the bearer token from FILE (surrounding whitespace trimmed)", ""},
    {"tls-ca", "PEM", "CA certificate to verify the server (TLS)", ""},
    {"tls-cert", "PEM", "client certificate (mutual TLS)", ""},
    {"tls-key", "PEM", "client private key (mutual TLS)", ""},
    {"db", "FILE", "embedded job store (also $WORMDRAG_DB)", "wormdrag.db"},
};

}  // namespace

std::vector<Option> RemoteOptionSpecs() {
  return kRemoteSpecs;
}

namespace remote {

std::vector<Option> With(std::vector<Option> own) {
  own.insert(own.end(), kRemoteSpecs.begin(), kRemoteSpecs.end());
  return own;
}

bool Remote(const Args& a) {
  return a.Has("server") || (!a.Has("db") && !rpc::EnvOr(rpc::kServerEnv, "").empty());
}

Result<rpc::ClientConfig> Config(const Args& a) {
  rpc::ClientConfig c;
  c.server = a.Get("server", rpc::EnvOr(rpc::kServerEnv, ""));
  auto token = rpc::ResolveToken(a.Get("token-file"), a.Get("token"));
  if (!token.ok()) return token.status();
  c.token = *token;
  c.tls_ca = a.Get("tls-ca");
  c.tls_cert = a.Get("tls-cert");
  c.tls_key = a.Get("tls-key");
  return c;
}

Result<std::unique_ptr<v2::JobService::Stub>> Stub(const rpc::ClientConfig& c) {
  auto ch = rpc::MakeChannel(c);
  if (!ch.ok()) return ch.status();
  return v2::JobService::NewStub(*ch);
}

Status Rpc(const grpc::Status& st, const rpc::ClientConfig& c) {
  Status s = rpc::FromGrpc(st);
  if (s.code() == Status::Code::kUnauthenticated)
    return Status::Unauthenticated("server " + c.server + " refused the call: " + s.message() +
                                   "; client commands take the client token from --token-file FILE or "
                                   "$WORMDRAG_TOKEN");
  if (s.code() == Status::Code::kPermissionDenied)
    return Status::PermissionDenied("server " + c.server + " knows this token but not as a client's: " + s.message() +
                                    "; client commands need the client token (--token-file FILE or "
                                    "$WORMDRAG_TOKEN), not the one given to workers");
  if (s.code() != Status::Code::kUnavailable) return s;
  // A TLS handshake the server refused looks like any closed connection here.
  const std::string hint = c.tls_ca.empty()
                               ? " (if the server uses TLS, give --tls-ca)"
                               : (c.tls_cert.empty()
                                      ? " (if the server requires mutual TLS, give --tls-cert and --tls-key)"
                                      : " (or it does not accept this certificate)");
  return s.Annotate("server " + c.server + " unreachable" + hint);
}

const char* StateName(v2::JobState s) {
  switch (s) {
    case v2::JOB_STATE_QUEUED:
      return "queued";
    case v2::JOB_STATE_RUNNING:
      return "running";
    case v2::JOB_STATE_DONE:
      return "done";
    case v2::JOB_STATE_FAILED:
      return "failed";
    case v2::JOB_STATE_CANCELLED:
      return "cancelled";
    default:
      return "unknown";
  }
}

bool Terminal(v2::JobState s) {
  return s == v2::JOB_STATE_DONE || s == v2::JOB_STATE_FAILED || s == v2::JOB_STATE_CANCELLED;
}

std::string ProgressLine(const v2::JobProgress& p) {
  const auto& j = p.job();
  const int width = 20;
  const double f = j.sets_total() > 0 ? static_cast<double>(j.sets_done()) / static_cast<double>(j.sets_total()) : 0;
  std::string bar(static_cast<size_t>(width * std::min(1.0, f)), '#');
  bar.resize(width, '-');
  char buf[400];
  // A diagnosis counts fits (or per mille of a local stage) and has no best E; an
  // estimate's bootstrap counts refits.
  const bool diagnosis = j.kind() == "diagnose";
  const char* unit = diagnosis ? (j.phase() == "fits" || j.phase() == "base fit" ? "fits" : "/1000")
                               : ProgressUnit(j.phase());
  std::snprintf(buf, sizeof buf,
                "%-15s [%s] %lld/%lld %s | tasks %lld queued %lld leased %lld done | %d workers | %.1f %s/s ETA %s%s%s",
                j.phase().empty() ? StateName(j.state()) : j.phase().c_str(), bar.c_str(),
                static_cast<long long>(j.sets_done()), static_cast<long long>(j.sets_total()), unit,
                static_cast<long long>(p.tasks_queued()), static_cast<long long>(p.tasks_leased()),
                static_cast<long long>(p.tasks_done()), p.workers(), p.sets_per_second(), diagnosis ? "fits" : unit,
                p.eta_seconds() >= 0 ? FormatDuration(p.eta_seconds()).c_str() : "?", diagnosis ? "" : " | best E ",
                diagnosis ? "" : (FormatE(j.best_e()) + " mm").c_str());
  return buf;
}

int WatchRemote(v2::JobService::Stub& stub, const rpc::ClientConfig& c, int64_t id, const char* cmd) {
  const bool tty = StderrIsTerminal();
  std::string last_phase;
  auto last_print = std::chrono::steady_clock::now() - std::chrono::seconds(60);
  for (int attempt = 0;; ++attempt) {
    grpc::ClientContext ctx;
    // A watch may last as long as the job: the deadline bounds one stream, which is
    // then reopened.
    rpc::Prepare(&ctx, c.token, 3600);
    v2::WatchJobRequest req;
    req.set_job_id(id);
    auto reader = stub.WatchJob(&ctx, req);
    v2::JobProgress p;
    bool ended = false;
    while (reader->Read(&p)) {
      attempt = 0;
      const auto now = std::chrono::steady_clock::now();
      const std::string line = ProgressLine(p);
      if (tty) {
        std::fprintf(stderr, "\r%s\033[K", line.c_str());
      } else if (p.job().phase() != last_phase || Terminal(p.job().state()) ||
                 now - last_print > std::chrono::seconds(5)) {
        std::fprintf(stderr, "%s\n", line.c_str());
        last_print = now;
      }
      last_phase = p.job().phase();
      if (Terminal(p.job().state())) ended = true;
    }
    grpc::Status st = reader->Finish();
    if (tty) std::fprintf(stderr, "\n");
    if (ended) {
      const auto& j = p.job();
      std::fprintf(stderr, "wormdrag %s: job %lld %s%s%s\n", cmd, static_cast<long long>(id), StateName(j.state()),
                   j.error().empty() ? "" : ": ", j.error().c_str());
      return j.state() == v2::JOB_STATE_DONE ? 0 : 1;
    }
    const bool transient = st.error_code() == grpc::StatusCode::UNAVAILABLE ||
                           st.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED || st.ok();
    if (!transient || attempt > 60) return Fail(cmd, Rpc(st, c));
    std::this_thread::sleep_for(std::chrono::seconds(1));  // the coordinator may be restarting
  }
}

int PrintResult(v2::JobService::Stub& stub, const rpc::ClientConfig& c, int64_t id, bool json, const char* cmd,
                const std::string& save_json) {
  grpc::ClientContext ctx;
  rpc::Prepare(&ctx, c.token, 30);
  v2::GetResultsRequest req;
  req.set_job_id(id);
  v2::GetResultsResponse resp;
  grpc::Status st = stub.GetResults(&ctx, req, &resp);
  if (!st.ok()) return Fail(cmd, Rpc(st, c));
  if (resp.job().state() != v2::JOB_STATE_DONE)
    return Fail(cmd, Status::FailedPrecondition("job " + std::to_string(id) + " is " + StateName(resp.job().state()) +
                                                (resp.job().error().empty() ? "" : ": " + resp.job().error())));
  if (!save_json.empty()) {
    Status w = WriteFileAtomically(save_json, ResultJson(resp) + "\n");
    if (!w.ok()) return Fail(cmd, w);
  }
  if (json)
    std::printf("%s\n", ResultJson(resp).c_str());
  else
    std::printf("job %lld\n%s", static_cast<long long>(id), ResultText(resp).c_str());
  return 0;
}

}  // namespace remote
}  // namespace wormdrag::cli
