// wormdrag-worker: pulls tasks from a wormdrag-server and simulates their
// coefficient sets with all its cores (the same LocalEvaluator as embedded runs).
#include <sys/resource.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include <spdlog/spdlog.h>

#include "core/store/job_store.h"
#include "proto/convert.h"
#include "proto/rpc_util.h"
#include "server/service_main.h"
#include "worker/task_runner.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace v2 = wormdrag::v2;
using namespace wormdrag;

namespace {

wormdrag::flags::Spec WorkerSpec() {
  return {"wormdrag-worker",
          "--server HOST:PORT [options]",
          "Worker of the wormdrag batch service: leases tasks (chunks of coefficient sets of an\n"
          "estimation, or one fit of a diagnosis) from the coordinator, simulates them on all\n"
          "cores, reports the results. Datasets are\n"
          "fetched once by content hash and cached. Reconnects with exponential backoff while\n"
          "the coordinator is away. SIGTERM/SIGINT: finish and report the current task, exit 0.",
          {
              {"server", "HOST:PORT", "coordinator", "$WORMDRAG_SERVER"},
              {"token", "T", "bearer token", "$WORMDRAG_TOKEN"},
              {"token-file", "FILE", "read the bearer token from FILE (keeps it out of `ps`)", ""},
              {"threads", "N", "simulation threads", "all hardware threads"},
              {"id", "NAME", "worker id in the coordinator's logs", "host:pid"},
              {"tls-ca", "PEM", "verify the coordinator's TLS certificate with this CA", ""},
              {"tls-cert", "PEM", "client certificate for mutual TLS (and --tls-key)", ""},
              {"tls-key", "PEM", "the client certificate's private key (with --tls-cert)", ""},
              {"cache-dir", "DIR", "also keep fetched datasets here (by SHA-256)", ""},
              {"idle-exit", "S", "exit 0 after S seconds without a task (batch schedulers); 0 = never", ""},
              {"max-message-mb", "M", "largest message", "64"},
              {"log-json", "", "one JSON object per log line", ""},
              {"help", "", "this text", ""},
          },
          false};
}

// Test-only (tests/integration, docs/reliability.md): with WORMDRAG_TEST_ABORT_ON_TASK
// set to a task-id prefix ("t1-" = every task of job 1), the worker abort()s when it
// leases a matching task: a poison task that kills every worker that takes it. Unset
// in production; not an option, so it cannot be set by accident on a command line.
std::string g_abort_on_task;
// Test-only, the same way: WORMDRAG_TEST_STOP_ON_TASK=PREFIX makes the worker stop
// itself (SIGSTOP, every thread: no heartbeats) once, when it leases a matching task;
// WORMDRAG_TEST_WRONG_VALUES=R makes it report every E value and residual multiplied
// by 1 + R: plausible but wrong results, for the spot-check tests.
std::string g_stop_on_task;
double g_wrong_values = 0;

std::atomic<bool> g_draining{false};
std::mutex g_ctx_mu;
grpc::ClientContext* g_lease_ctx = nullptr;  // the long poll in flight, cancelled on drain
std::mutex g_sleep_mu;
std::condition_variable g_sleep_cv;

// Sleeps, waking early when draining starts.
void Sleep(std::chrono::milliseconds d) {
  std::unique_lock<std::mutex> l(g_sleep_mu);
  g_sleep_cv.wait_for(l, d, [] { return g_draining.load(); });
}

class Backoff {
 public:
  std::chrono::milliseconds Next() {
    std::uniform_real_distribution<double> jitter(0.8, 1.2);
    const auto d = std::chrono::milliseconds(static_cast<int64_t>(ms_ * jitter(rng_)));
    ms_ = std::min(ms_ * 2, 5000.0);
    return d;
  }
  void Reset() { ms_ = 100; }

 private:
  double ms_ = 100;
  std::mt19937 rng_{std::random_device{}()};
};

class Worker {
 public:
  Worker(std::shared_ptr<grpc::Channel> ch, std::string token, std::string id, int threads, std::string cache_dir)
      : stub_(v2::WorkerService::NewStub(ch)),
        token_(std::move(token)),
        id_(std::move(id)),
        threads_(threads),
        cache_dir_(std::move(cache_dir)),
        runner_([this](const std::string& hash, const std::string& name) { return Dataset(hash, name); }, threads) {}

  int Run(double idle_exit) {
    Backoff backoff;
    auto last_task = std::chrono::steady_clock::now();
    bool connected = false;
    while (!g_draining) {
      v2::LeaseTaskRequest req;
      req.set_worker_id(id_);
      req.set_threads(threads_);
      req.set_wait_ms(5000);
      v2::LeaseTaskResponse resp;
      grpc::ClientContext ctx;
      rpc::Prepare(&ctx, token_, 20);
      {
        std::lock_guard<std::mutex> l(g_ctx_mu);
        g_lease_ctx = &ctx;
      }
      if (g_draining) ctx.TryCancel();
      grpc::Status st = stub_->LeaseTask(&ctx, req, &resp);
      {
        std::lock_guard<std::mutex> l(g_ctx_mu);
        g_lease_ctx = nullptr;
      }
      if (g_draining) break;
      if (!st.ok()) {
        // A wrong credential, a refused request or a quarantined worker: retrying
        // cannot help.
        if (st.error_code() == grpc::StatusCode::UNAUTHENTICATED ||
            st.error_code() == grpc::StatusCode::PERMISSION_DENIED ||
            st.error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
          spdlog::error("event=rejected code={} error=\"{}\"", static_cast<int>(st.error_code()), st.error_message());
          return 2;
        }
        // A coordinator of another wire version does not know wormdrag.v2.WorkerService.
        if (st.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
          spdlog::error(
              "event=wrong_version error=\"{}\" (this worker speaks wormdrag.v2: run the coordinator's version)",
              st.error_message());
          return 2;
        }
        const auto d = backoff.Next();
        spdlog::warn("event=coordinator_unreachable code={} error=\"{}\" retry_ms={}",
                     static_cast<int>(st.error_code()), st.error_message(), d.count());
        connected = false;
        Sleep(d);
        continue;
      }
      if (!connected) {
        spdlog::info("event=connected worker={} threads={}", id_, threads_);
        connected = true;
      }
      backoff.Reset();
      if (!resp.has_task()) {
        if (idle_exit > 0 &&
            std::chrono::duration<double>(std::chrono::steady_clock::now() - last_task).count() > idle_exit) {
          spdlog::info("event=idle_exit seconds={}", idle_exit);
          return 0;
        }
        continue;
      }
      const v2::Task& task = resp.task();
      spdlog::info("event=task_leased task={} job={} sets={} worm={} cut={}", task.task_id(), task.job_id(),
                   task.sets_size(), task.worm(),
                   task.keep() > 0            ? "phase"
                   : task.set_cuts_size() > 0 ? "groups"
                                              : "none");
      Process(resp.task());
      last_task = std::chrono::steady_clock::now();
    }
    spdlog::info("event=drained worker={} tasks_done={}", id_, tasks_done_);
    return 0;
  }

 private:
  Result<std::string> Dataset(const std::string& hash, const std::string& name) {
    if (auto it = datasets_.find(hash); it != datasets_.end()) return it->second;
    namespace fs = std::filesystem;
    const std::string file = cache_dir_.empty() ? "" : (fs::path(cache_dir_) / (hash + ".kin")).string();
    if (!file.empty() && fs::exists(file)) {
      auto text = rpc::ReadText(file);
      if (text.ok() && Sha256Hex(*text) == hash) return datasets_[hash] = *text;
    }
    Backoff backoff;
    for (int attempt = 0;; ++attempt) {
      v2::GetDatasetRequest req;
      req.set_hash(hash);
      v2::GetDatasetResponse resp;
      grpc::ClientContext ctx;
      rpc::Prepare(&ctx, token_, 60);
      grpc::Status st = stub_->GetDataset(&ctx, req, &resp);
      if (st.ok()) {
        if (Sha256Hex(resp.content()) != hash)
          return Status::Internal("dataset " + name + ": content does not match its hash " + hash);
        if (!file.empty()) {
          std::error_code ec;
          fs::create_directories(cache_dir_, ec);
          std::ofstream(file + ".tmp", std::ios::binary) << resp.content();
          fs::rename(file + ".tmp", file, ec);
        }
        spdlog::info("event=dataset_fetched hash={} name={} bytes={}", hash.substr(0, 12), name, resp.content().size());
        return datasets_[hash] = resp.content();
      }
      if (st.error_code() != grpc::StatusCode::UNAVAILABLE || attempt > 20) return rpc::FromGrpc(st);
      Sleep(backoff.Next());
    }
  }

  void Process(const v2::Task& t) {
    if (!g_abort_on_task.empty() && t.task_id().rfind(g_abort_on_task, 0) == 0) {
      spdlog::critical("event=test_abort task={} (WORMDRAG_TEST_ABORT_ON_TASK={})", t.task_id(), g_abort_on_task);
      const rlimit no_core{0, 0};  // a crash, not a core file per test run
      setrlimit(RLIMIT_CORE, &no_core);
      std::abort();
    }
    if (!g_stop_on_task.empty() && t.task_id().rfind(g_stop_on_task, 0) == 0) {
      spdlog::warn("event=test_stop task={} (WORMDRAG_TEST_STOP_ON_TASK={})", t.task_id(), g_stop_on_task);
      spdlog::default_logger()->flush();
      g_stop_on_task.clear();
      raise(SIGSTOP);
    }
    const auto t0 = std::chrono::steady_clock::now();
    std::atomic<bool> done{false}, cancelled{false};
    std::mutex hb_mu;
    std::condition_variable hb_cv;
    // Heartbeats at a third of the lease keep it alive while simulating.
    std::thread hb([&] {
      const auto period = std::chrono::milliseconds(std::max<int64_t>(200, t.lease_seconds() * 1000 / 3));
      std::unique_lock<std::mutex> l(hb_mu);
      while (!hb_cv.wait_for(l, period, [&] { return done.load(); })) {
        l.unlock();
        v2::HeartbeatRequest req;
        req.set_worker_id(id_);
        req.add_task_ids(t.task_id());
        v2::HeartbeatResponse resp;
        grpc::ClientContext ctx;
        rpc::Prepare(&ctx, token_, 5);
        if (stub_->Heartbeat(&ctx, req, &resp).ok()) {
          heard_ = std::chrono::steady_clock::now();
          for (const auto& c : resp.cancelled_task_ids())
            if (c == t.task_id()) cancelled = true;
        }
        l.lock();
      }
    });
    v2::ReportResultRequest rep;
    rep.set_worker_id(id_);
    rep.set_task_id(t.task_id());
    rep.set_lease_id(t.lease_id());
    runner_.Run(t, &rep);
    if (g_wrong_values != 0 && t.kind() != v2::TASK_KIND_DIAGNOSE_FIT &&
        t.kind() != v2::TASK_KIND_BOOTSTRAP_REPLICATE) {
      for (double& v : *rep.mutable_values()) v *= 1 + g_wrong_values;
      for (auto& r : *rep.mutable_residuals())
        for (double& v : *r.mutable_values()) v *= 1 + g_wrong_values;
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Heartbeats go on while the report is retried (a coordinator whose disk is full
    // refuses it for a while): the lease stays this worker's, so the result, once
    // accepted, still comes from the lease holder.
    if (cancelled)
      spdlog::info("event=task_dropped task={} job={} reason=cancelled", t.task_id(), t.job_id());
    else
      Report(rep, t, secs, cancelled);
    {
      std::lock_guard<std::mutex> l(hb_mu);
      done = true;
    }
    hb_cv.notify_all();
    hb.join();
  }

  // Retries while the coordinator is unreachable or busy: until the lease is lost
  // (`cancelled`, from the heartbeats), or the coordinator has not answered a
  // heartbeat for 2 minutes (a coordinator that answers but cannot store, its disk
  // full, is waited for), or 30 minutes pass.
  void Report(const v2::ReportResultRequest& rep, const v2::Task& t, double secs, const std::atomic<bool>& cancelled) {
    Backoff backoff;
    heard_ = std::chrono::steady_clock::now();
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(30);
    for (;;) {
      v2::ReportResultResponse resp;
      grpc::ClientContext ctx;
      rpc::Prepare(&ctx, token_, 30);
      grpc::Status st = stub_->ReportResult(&ctx, rep, &resp);
      if (st.ok()) {
        ++tasks_done_;
        const auto abandoned = std::count_if(rep.values().begin(), rep.values().end(),
                                             [](double v) { return std::isnan(v); });
        spdlog::info("event=task_reported task={} job={} sets={} seconds={:.3f} abandoned={} duplicate={}{}",
                     t.task_id(), t.job_id(), t.sets_size(), secs, abandoned, resp.duplicate(),
                     rep.error().empty() ? "" : " error=\"" + rep.error() + "\"");
        return;
      }
      const bool retry = st.error_code() == grpc::StatusCode::UNAVAILABLE ||
                         st.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED;
      const auto now = std::chrono::steady_clock::now();
      if (!retry || cancelled || now > give_up || now - heard_.load() > std::chrono::minutes(2)) {
        spdlog::warn("event=report_dropped task={} code={} error=\"{}\"", t.task_id(),
                     static_cast<int>(st.error_code()), st.error_message());
        return;
      }
      const auto d = backoff.Next();
      spdlog::warn("event=report_retry task={} error=\"{}\" retry_ms={}", t.task_id(), st.error_message(), d.count());
      // Not interruptible by draining: the result is worth delivering.
      std::this_thread::sleep_for(d);
    }
  }

  std::unique_ptr<v2::WorkerService::Stub> stub_;
  std::string token_, id_;
  int threads_;
  std::string cache_dir_;
  std::map<std::string, std::string> datasets_;
  worker::TaskRunner runner_;
  int64_t tasks_done_ = 0;
  std::atomic<std::chrono::steady_clock::time_point> heard_{};  // last heartbeat answered
};

}  // namespace

int main(int argc, char** argv) {
  service::ServiceMain svc(WorkerSpec());  // first: blocks the signals WaitForSignal takes
  if (auto rc = svc.Start(argc, argv)) return *rc;
  const flags::Args& f = svc.flags();
  rpc::ClientConfig cfg;
  cfg.server = f.Get("server", rpc::EnvOr(rpc::kServerEnv, ""));
  auto token = rpc::ResolveToken(f.Get("token-file"), f.Get("token"));
  if (!token.ok()) return svc.Die(token.status().message());
  cfg.token = *token;
  cfg.tls_ca = f.Get("tls-ca");
  cfg.tls_cert = f.Get("tls-cert");
  cfg.tls_key = f.Get("tls-key");
  long n;
  int threads = DefaultThreads();
  if (f.Has("threads")) {
    if (!flags::ToLong(f.Get("threads"), &n) || n < 1 || n > 1024)
      return svc.Die("--threads must be between 1 and 1024");
    threads = static_cast<int>(n);
  }
  if (f.Has("max-message-mb")) {
    if (!flags::ToLong(f.Get("max-message-mb"), &n) || n < 1 || n > 2000) return svc.Die("--max-message-mb: 1 to 2000");
    cfg.max_message_mb = static_cast<int>(n);
  }
  double idle_exit = 0;
  if (f.Has("idle-exit") && (!flags::ToDouble(f.Get("idle-exit"), &idle_exit) || idle_exit < 0))
    return svc.Die("--idle-exit must be a number of seconds >= 0");
  if (const char* a = std::getenv("WORMDRAG_TEST_ABORT_ON_TASK")) g_abort_on_task = a;
  if (const char* a = std::getenv("WORMDRAG_TEST_STOP_ON_TASK")) g_stop_on_task = a;
  if (const char* a = std::getenv("WORMDRAG_TEST_WRONG_VALUES")) g_wrong_values = std::atof(a);
  char host[256] = "worker";
  gethostname(host, sizeof host - 1);
  const std::string id = f.Get("id", std::string(host) + ":" + std::to_string(getpid()));
  auto ch = rpc::MakeChannel(cfg);
  if (!ch.ok()) return svc.Die(ch.status().message());

  std::thread([&svc] {
    const char* sig = "";
    svc.WaitForSignal(&sig);
    spdlog::info("event=draining signal={}", sig);
    g_draining = true;
    {
      std::lock_guard<std::mutex> l(g_ctx_mu);
      if (g_lease_ctx) g_lease_ctx->TryCancel();
    }
    g_sleep_cv.notify_all();
  }).detach();

  spdlog::info("event=start worker={} pid={} server={} threads={}", id, getpid(), cfg.server, threads);
  Worker w(*ch, cfg.token, id, threads, f.Get("cache-dir"));
  const int rc = w.Run(idle_exit);
  spdlog::shutdown();
  std::fflush(nullptr);
  _exit(rc);
}
