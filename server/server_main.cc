// wormdrag-server: the coordinator of the distributed estimation service.
#include <unistd.h>
#include <atomic>
#include <cstdio>
#include <thread>

#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/spdlog.h>

#include "proto/rpc_util.h"
#include "server/coordinator.h"
#include "server/service_main.h"
#include "server/services.h"
#include "server/status_http.h"

namespace {

wormdrag::flags::Spec ServerSpec() {
  return {"wormdrag-server",
          "--db FILE [--listen HOST:PORT] [options]",
          "Coordinator of the wormdrag batch service: accepts estimation and diagnosis jobs (JobService),\n"
          "splits Phases 1-3 and a diagnosis's fits into tasks leased to wormdrag-worker processes\n"
          "(WorkerService), stores every result in SQLite and resumes unfinished jobs after a restart.\n"
          "Also serves the standard gRPC health service (grpc.health.v1.Health).",
          {
              {"listen", "HOST:PORT", "address to serve on", "127.0.0.1:50051"},
              {"db", "FILE", "SQLite job store (created if absent; WAL, synchronous=FULL)", ""},
              {"token", "T", "clients must send this bearer token", "$WORMDRAG_TOKEN; none = open"},
              {"token-file", "FILE", "read the client token from FILE (keeps it out of `ps`)", ""},
              {"worker-token", "T",
               "token workers must send; when it differs from the client token,\n"
               "each token is refused (PERMISSION_DENIED) by the other service",
               "the client token"},
              {"worker-token-file", "FILE", "read the worker token from FILE", ""},
              {"insecure", "",
               "allow listening beyond loopback with no token and no client\n"
               "certificates: anyone who reaches the port may submit jobs and act as a worker",
               ""},
              {"tls-cert", "PEM", "serve TLS with this certificate (and --tls-key)", ""},
              {"tls-key", "PEM", "the certificate's private key (with --tls-cert)", ""},
              {"tls-client-ca", "PEM", "also require client certificates signed by this CA (mutual TLS)", ""},
              {"lease-seconds", "S", "lease of a task without heartbeat", "30"},
              {"max-attempts", "N", "worker failures before a task is quarantined", "3"},
              {"max-lost-leases", "N",
               "leases of a task lost (its worker died, stalled past --lease-seconds\n"
               "or ran past the deadline) before it is quarantined",
               "3"},
              {"task-deadline", "S[,P]",
               "execution deadline of a leased task: S seconds plus P per\n"
               "coefficient set it carries; heartbeats do not extend it",
               "900,2"},
              {"spot-check-fraction", "F",
               "fraction of E and residual tasks run again on a different worker;\n"
               "a third worker decides when they differ and the odd one out is\n"
               "quarantined (0 = off; skipped while only one worker is live)",
               "0.02"},
              {"max-running-jobs", "N", "jobs run at once; later ones stay queued until one ends", "2"},
              {"max-rpc-threads", "N",
               "threads serving gRPC calls (a worker holds about two: its lease\n"
               "poll and heartbeats); calls beyond get RESOURCE_EXHAUSTED",
               "512"},
              {"sqlite-busy-ms", "MS",
               "wait this long for another process's SQLite write lock, then\n"
               "retry with back-off for --busy-retry-seconds",
               "5000"},
              {"busy-retry-seconds", "S", "how long writes retry a busy SQLite lock", "300"},
              {"chunk-sets", "N",
               "most coefficient sets per task, multiple of 8 (default 128); each\n"
               "batch is cut into at least as many tasks as there are workers",
               ""},
              {"parallelism", "N",
               "evaluator batch = 32 N sets (default 16: 512 sets, bit-identical\n"
               "to an embedded run with 2 threads; 8 T matches T threads); a batch\n"
               "feeds up to 4 N workers (one 8-set lane group each)",
               ""},
              {"max-message-mb", "M", "largest request accepted (default 64): bounds recording size", ""},
              {"max-sets", "N", "largest Phase 1 grid a job may ask for", "200000"},
              {"max-null-replicates", "N", "largest diagnosis a job may ask for", "50"},
              {"http", "[HOST:]PORT",
               "also serve a read-only status page (/) and Prometheus /metrics\n"
               "over HTTP (HTTPS with --tls-cert); HOST defaults to 127.0.0.1; the\n"
               "token goes in an Authorization: Bearer header or a ?token= query",
               ""},
              {"log-json", "", "one JSON object per log line", ""},
              {"help", "", "this text", ""},
          },
          false};
}

struct Tokens {
  std::string client, worker;
};

// Both bearer tokens, each from its file or flag; the client's falls back to
// $WORMDRAG_TOKEN, the workers' to the client's. An unreadable or empty file is an error
// naming it.
wormdrag::Result<Tokens> ResolveTokens(const wormdrag::flags::Args& f) {
  auto client = wormdrag::rpc::ResolveToken(f.Get("token-file"), f.Get("token"));
  if (!client.ok()) return client.status();
  auto worker = wormdrag::rpc::ResolveToken(f.Get("worker-token-file"), f.Get("worker-token", *client));
  if (!worker.ok()) return worker.status();
  return Tokens{*client, *worker};
}

// A numeric flag, when given: false unless it is a number in [lo, hi] (LongFlag: a whole
// number and a multiple of `multiple`). When absent, `out` keeps its default.
bool LongFlag(const wormdrag::flags::Args& f, const char* name, long lo, long hi, int* out, long multiple = 1) {
  if (!f.Has(name)) return true;
  long n;
  if (!wormdrag::flags::ToLong(f.Get(name), &n) || n < lo || n > hi || n % multiple) return false;
  *out = static_cast<int>(n);
  return true;
}
bool DoubleFlag(const wormdrag::flags::Args& f, const char* name, double lo, double hi, double* out) {
  if (!f.Has(name)) return true;
  double d;
  if (!wormdrag::flags::ToDouble(f.Get(name), &d) || !(d >= lo && d <= hi)) return false;
  *out = d;
  return true;
}

wormdrag::Result<wormdrag::server::CoordinatorOptions> CoordinatorOptionsFrom(const wormdrag::flags::Args& f) {
  using wormdrag::Status;
  constexpr double kAny = 1e300;
  constexpr long kMany = 2147483647;
  wormdrag::server::CoordinatorOptions o;
  o.db_path = f.Get("db");
  if (!DoubleFlag(f, "lease-seconds", 1, kAny, &o.lease_seconds))
    return Status::InvalidArgument("--lease-seconds must be a number >= 1");
  if (!LongFlag(f, "max-attempts", 1, kMany, &o.max_attempts))
    return Status::InvalidArgument("--max-attempts must be >= 1");
  if (!LongFlag(f, "max-lost-leases", 1, kMany, &o.max_lost_leases))
    return Status::InvalidArgument("--max-lost-leases must be >= 1");
  if (f.Has("task-deadline")) {
    const std::string v = f.Get("task-deadline");
    const size_t comma = v.find(',');
    double d, per_set = o.deadline_seconds_per_set;
    if (!wormdrag::flags::ToDouble(v.substr(0, comma), &d) || d < 1 ||
        (comma != std::string::npos && (!wormdrag::flags::ToDouble(v.substr(comma + 1), &per_set) || per_set < 0)))
      return Status::InvalidArgument("--task-deadline must be S (>= 1) or S,P (P >= 0) seconds");
    o.deadline_seconds = d;
    o.deadline_seconds_per_set = per_set;
  }
  if (!DoubleFlag(f, "spot-check-fraction", 0, 1, &o.spot_check_fraction))
    return Status::InvalidArgument("--spot-check-fraction must be between 0 and 1");
  if (!LongFlag(f, "max-running-jobs", 1, 10000, &o.max_running_jobs))
    return Status::InvalidArgument("--max-running-jobs must be between 1 and 10000");
  if (!LongFlag(f, "sqlite-busy-ms", 0, 600000, &o.busy_timeout_ms))
    return Status::InvalidArgument("--sqlite-busy-ms must be between 0 and 600000");
  if (!DoubleFlag(f, "busy-retry-seconds", 0, kAny, &o.busy_retry_seconds))
    return Status::InvalidArgument("--busy-retry-seconds must be >= 0");
  if (!LongFlag(f, "chunk-sets", 8, 100000, &o.chunk_sets, 8))
    return Status::InvalidArgument("--chunk-sets must be a multiple of 8 up to 100000");
  if (!LongFlag(f, "parallelism", 1, 100000, &o.parallelism))
    return Status::InvalidArgument("--parallelism must be >= 1");
  if (f.Has("max-sets")) {
    long n;
    if (!wormdrag::flags::ToLong(f.Get("max-sets"), &n) || n < 1)
      return Status::InvalidArgument("--max-sets must be >= 1");
    o.max_sets = n;
  }
  if (!LongFlag(f, "max-null-replicates", 2, kMany, &o.max_null_replicates))
    return Status::InvalidArgument("--max-null-replicates must be >= 2");
  return o;
}

// Credentials of the gRPC port: TLS (mutual with --tls-client-ca) or none.
wormdrag::Result<std::shared_ptr<grpc::ServerCredentials>> ServerCredentials(const wormdrag::flags::Args& f) {
  using wormdrag::Status;
  namespace rpc = wormdrag::rpc;
  if (!f.Has("tls-cert") && !f.Has("tls-key")) {
    if (f.Has("tls-client-ca")) return Status::InvalidArgument("--tls-client-ca needs --tls-cert and --tls-key");
    return grpc::InsecureServerCredentials();
  }
  auto cert = rpc::ReadText(f.Get("tls-cert")), key = rpc::ReadText(f.Get("tls-key"));
  if (!cert.ok() || !key.ok()) return Status::InvalidArgument("TLS needs readable --tls-cert and --tls-key PEM files");
  grpc::SslServerCredentialsOptions so(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  so.pem_key_cert_pairs.push_back({*key, *cert});
  if (f.Has("tls-client-ca")) {
    auto ca = rpc::ReadText(f.Get("tls-client-ca"));
    if (!ca.ok()) return ca.status();
    so.pem_root_certs = *ca;
    so.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(so);
}

// The health service follows the store: NOT_SERVING while its disk is full (load
// balancers and `grpc_health_probe` see it), SERVING again once space returns.
void FollowStorage(grpc::Server* srv, const wormdrag::server::Coordinator* c, const std::atomic<bool>* stopping) {
  bool serving = true;
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    if (*stopping) return;
    const bool ok = c->storage_ok();
    if (ok == serving) continue;
    serving = ok;
    srv->GetHealthCheckService()->SetServingStatus(ok);
    if (ok)
      spdlog::info("event=serving reason=\"storage writable again\"");
    else
      spdlog::error("event=not_serving reason=\"storage full\"");
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace wormdrag;
  service::ServiceMain svc(ServerSpec());  // first: blocks the signals WaitForSignal takes
  if (auto rc = svc.Start(argc, argv)) return *rc;
  const flags::Args& f = svc.flags();
  if (!f.Has("db")) return svc.Die("--db FILE is required (see --help)");
  auto options = CoordinatorOptionsFrom(f);
  if (!options.ok()) return svc.Die(options.status().message());
  const server::CoordinatorOptions& o = *options;
  int max_threads = 512, max_mb = 64;
  if (!LongFlag(f, "max-rpc-threads", 4, 100000, &max_threads))
    return svc.Die("--max-rpc-threads must be between 4 and 100000");
  if (!LongFlag(f, "max-message-mb", 1, 2000, &max_mb)) return svc.Die("--max-message-mb must be between 1 and 2000");
  auto tokens = ResolveTokens(f);
  if (!tokens.ok()) return svc.Die(tokens.status().message());
  const std::string token = tokens->client, worker_token = tokens->worker;
  const std::string listen = f.Get("listen", "127.0.0.1:50051");
  const bool exposed = !rpc::IsLoopbackAddress(listen);
  if (exposed && (token.empty() || worker_token.empty()) && !f.Has("tls-client-ca") && !f.Has("insecure"))
    return svc.Die("listening on " + listen +
                   " with no token: anyone who reaches the port may submit jobs and act as a worker; set "
                   "$WORMDRAG_TOKEN or --token-file (or require client certificates with --tls-client-ca), "
                   "or pass --insecure");
  if (exposed && !token.empty() && !f.Has("tls-cert"))
    spdlog::warn(
        "event=token_without_tls address={} reason=\"the bearer token crosses the network in clear text; serve "
        "TLS with --tls-cert and --tls-key\"",
        listen);

  auto creds = ServerCredentials(f);
  if (!creds.ok()) return svc.Die(creds.status().message());

  server::StatusHttpOptions http;
  if (f.Has("http")) {
    std::string error;
    if (!server::ParseHttpAddress(f.Get("http"), &http, &error)) return svc.Die(error);
    http.token = token;
    http.tls_cert = f.Get("tls-cert");
    http.tls_key = f.Get("tls-key");
    http.tls_client_ca = f.Get("tls-client-ca");
  }

  auto coord = server::Coordinator::Open(o);
  if (!coord.ok()) return svc.Die(coord.status().ToString());
  server::JobServiceImpl jobs(**coord, token, worker_token);
  server::WorkerServiceImpl workers(**coord, worker_token, token);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder b;
  int port = 0;
  // gRPC shares a port between processes by default (SO_REUSEPORT): a second
  // coordinator started by mistake on a busy port would take half the workers and
  // clients to another database. It fails to bind instead.
  b.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  b.AddListeningPort(listen, *creds, &port);
  b.SetMaxReceiveMessageSize(max_mb * 1024 * 1024);
  b.SetMaxSendMessageSize(max_mb * 1024 * 1024);
  // Each sync call holds a thread (long polls and watches for seconds): the quota
  // bounds them, so a flood of calls is refused instead of exhausting the process.
  grpc::ResourceQuota quota("wormdrag-server");
  quota.SetMaxThreads(max_threads);
  b.SetResourceQuota(quota);
  b.RegisterService(&jobs);
  b.RegisterService(&workers);
  std::unique_ptr<grpc::Server> srv = b.BuildAndStart();
  if (!srv || port == 0) return svc.Die("cannot listen on " + listen);
  srv->GetHealthCheckService()->SetServingStatus(true);
  spdlog::info(
      "event=listening address={} port={} db={} tls={} mtls={} auth={} lease_seconds={} max_lost_leases={} "
      "task_deadline={}+{}/set chunk_sets={} spot_check_fraction={} max_running_jobs={} max_rpc_threads={}",
      listen, port, o.db_path, f.Has("tls-cert"), f.Has("tls-client-ca"), !token.empty(), o.lease_seconds,
      o.max_lost_leases, o.deadline_seconds, o.deadline_seconds_per_set, o.chunk_sets, o.spot_check_fraction,
      o.max_running_jobs, max_threads);
  std::unique_ptr<server::StatusHttpServer> status_http;
  if (f.Has("http")) {
    auto h = server::StatusHttpServer::Start(**coord, http);
    if (!h.ok()) return svc.Die(h.status().message());
    status_http = std::move(*h);
  }
  if (Status st = (*coord)->ResumeJobs(); !st.ok()) return svc.Die(st.ToString());
  std::atomic<bool> stopping{false};
  std::thread(FollowStorage, srv.get(), coord->get(), &stopping).detach();

  const char* sig = "";
  svc.WaitForSignal(&sig);
  spdlog::info("event=shutdown signal={}", sig);
  stopping = true;
  srv->GetHealthCheckService()->SetServingStatus(false);
  // In-flight calls finish (a report being committed is acknowledged), long polls end.
  srv->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(3));
  status_http.reset();
  (*coord)->Shutdown();
  spdlog::info("event=stopped");
  spdlog::shutdown();
  std::fflush(nullptr);
  // Job threads are blocked on their tasks; everything acknowledged is durable and
  // their jobs resume on the next start, so leave without unwinding them.
  _exit(0);
}
