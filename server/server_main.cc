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

}  // namespace

int main(int argc, char** argv) {
  using namespace wormdrag;
  service::ServiceMain svc(ServerSpec());  // first: blocks the signals WaitForSignal takes
  if (auto rc = svc.Start(argc, argv)) return *rc;
  const flags::Args& f = svc.flags();
  if (!f.Has("db")) return svc.Die("--db FILE is required (see --help)");

  server::CoordinatorOptions o;
  o.db_path = f.Get("db");
  double d;
  long n;
  if (f.Has("lease-seconds")) {
    if (!flags::ToDouble(f.Get("lease-seconds"), &d) || d < 1) return svc.Die("--lease-seconds must be a number >= 1");
    o.lease_seconds = d;
  }
  if (f.Has("max-attempts")) {
    if (!flags::ToLong(f.Get("max-attempts"), &n) || n < 1) return svc.Die("--max-attempts must be >= 1");
    o.max_attempts = static_cast<int>(n);
  }
  if (f.Has("max-lost-leases")) {
    if (!flags::ToLong(f.Get("max-lost-leases"), &n) || n < 1) return svc.Die("--max-lost-leases must be >= 1");
    o.max_lost_leases = static_cast<int>(n);
  }
  if (f.Has("task-deadline")) {
    const std::string v = f.Get("task-deadline");
    const size_t comma = v.find(',');
    double per_set = o.deadline_seconds_per_set;
    if (!flags::ToDouble(v.substr(0, comma), &d) || d < 1 ||
        (comma != std::string::npos && (!flags::ToDouble(v.substr(comma + 1), &per_set) || per_set < 0)))
      return svc.Die("--task-deadline must be S (>= 1) or S,P (P >= 0) seconds");
    o.deadline_seconds = d;
    o.deadline_seconds_per_set = per_set;
  }
  if (f.Has("spot-check-fraction")) {
    if (!flags::ToDouble(f.Get("spot-check-fraction"), &d) || !(d >= 0 && d <= 1))
      return svc.Die("--spot-check-fraction must be between 0 and 1");
    o.spot_check_fraction = d;
  }
  if (f.Has("max-running-jobs")) {
    if (!flags::ToLong(f.Get("max-running-jobs"), &n) || n < 1 || n > 10000)
      return svc.Die("--max-running-jobs must be between 1 and 10000");
    o.max_running_jobs = static_cast<int>(n);
  }
  int max_threads = 512;
  if (f.Has("max-rpc-threads")) {
    if (!flags::ToLong(f.Get("max-rpc-threads"), &n) || n < 4 || n > 100000)
      return svc.Die("--max-rpc-threads must be between 4 and 100000");
    max_threads = static_cast<int>(n);
  }
  if (f.Has("sqlite-busy-ms")) {
    if (!flags::ToLong(f.Get("sqlite-busy-ms"), &n) || n < 0 || n > 600000)
      return svc.Die("--sqlite-busy-ms must be between 0 and 600000");
    o.busy_timeout_ms = static_cast<int>(n);
  }
  if (f.Has("busy-retry-seconds")) {
    if (!flags::ToDouble(f.Get("busy-retry-seconds"), &d) || d < 0) return svc.Die("--busy-retry-seconds must be >= 0");
    o.busy_retry_seconds = d;
  }
  if (f.Has("chunk-sets")) {
    if (!flags::ToLong(f.Get("chunk-sets"), &n) || n < 8 || n % 8 || n > 100000)
      return svc.Die("--chunk-sets must be a multiple of 8 up to 100000");
    o.chunk_sets = static_cast<int>(n);
  }
  if (f.Has("parallelism")) {
    if (!flags::ToLong(f.Get("parallelism"), &n) || n < 1 || n > 100000) return svc.Die("--parallelism must be >= 1");
    o.parallelism = static_cast<int>(n);
  }
  if (f.Has("max-sets")) {
    if (!flags::ToLong(f.Get("max-sets"), &n) || n < 1) return svc.Die("--max-sets must be >= 1");
    o.max_sets = n;
  }
  if (f.Has("max-null-replicates")) {
    if (!flags::ToLong(f.Get("max-null-replicates"), &n) || n < 2) return svc.Die("--max-null-replicates must be >= 2");
    o.max_null_replicates = static_cast<int>(n);
  }
  int max_mb = 64;
  if (f.Has("max-message-mb")) {
    if (!flags::ToLong(f.Get("max-message-mb"), &n) || n < 1 || n > 2000)
      return svc.Die("--max-message-mb must be between 1 and 2000");
    max_mb = static_cast<int>(n);
  }
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

  std::shared_ptr<grpc::ServerCredentials> creds;
  if (f.Has("tls-cert") || f.Has("tls-key")) {
    auto cert = rpc::ReadText(f.Get("tls-cert")), key = rpc::ReadText(f.Get("tls-key"));
    if (!cert.ok() || !key.ok()) return svc.Die("TLS needs readable --tls-cert and --tls-key PEM files");
    grpc::SslServerCredentialsOptions so(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
    so.pem_key_cert_pairs.push_back({*key, *cert});
    if (f.Has("tls-client-ca")) {
      auto ca = rpc::ReadText(f.Get("tls-client-ca"));
      if (!ca.ok()) return svc.Die(ca.status().message());
      so.pem_root_certs = *ca;
      so.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
    }
    creds = grpc::SslServerCredentials(so);
  } else {
    if (f.Has("tls-client-ca")) return svc.Die("--tls-client-ca needs --tls-cert and --tls-key");
    creds = grpc::InsecureServerCredentials();
  }

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
  b.AddListeningPort(listen, creds, &port);
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
  // The health service follows the store: NOT_SERVING while its disk is full (load
  // balancers and `grpc_health_probe` see it), SERVING again once space returns.
  std::atomic<bool> stopping{false};
  std::thread([&srv, &stopping, c = coord->get()] {
    bool serving = true;
    for (;;) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      if (stopping) return;
      const bool ok = c->storage_ok();
      if (ok == serving) continue;
      serving = ok;
      srv->GetHealthCheckService()->SetServingStatus(ok);
      if (ok)
        spdlog::info("event=serving reason=\"storage writable again\"");
      else
        spdlog::error("event=not_serving reason=\"storage full\"");
    }
  }).detach();

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
