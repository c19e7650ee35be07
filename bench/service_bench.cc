// Coordinator capacity: many simulated fast workers (threads that lease a task and
// report made-up values at once) against a real wormdrag-server over loopback.
// Measures leases/s and results (sets) ingested/s during Phase 1 of `--jobs` jobs
// submitted at once (the scheduler deals their tasks round-robin), then cancels them.
//
//   service_bench --server 127.0.0.1:PORT [--workers 32] [--jobs 1] [--n-max 10] [--recording K.csv]
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "core/common/flags.h"
#include "proto/rpc_util.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace v2 = wormdrag::v2;

int main(int argc, char** argv) {
  const wormdrag::flags::Spec spec{
      "service_bench",
      "--server 127.0.0.1:PORT --recording K.csv [--workers 32] [--jobs 1] [--n-max 10]",
      "Coordinator capacity: simulated fast workers against a real wormdrag-server; leases/s and\n"
      "sets ingested/s during Phase 1 of --jobs jobs submitted at once (BENCHMARKS.md, \"Service\").",
      {{"server", "HOST:PORT", "the coordinator", "127.0.0.1:50051"},
       {"recording", "K.csv", "recording of both worms of every job (required)", ""},
       {"workers", "N", "simulated workers", "32"},
       {"jobs", "J", "jobs submitted at once", "1"},
       {"n-max", "N", "the jobs' n_max", "10"}},
      false};
  wormdrag::flags::Args args;
  if (auto rc = wormdrag::flags::Parse(wormdrag::flags::ArgList(argc, argv), spec, &args)) return *rc;
  const std::string server = args.Get("server", "127.0.0.1:50051"), recording = args.Get("recording");
  const int workers = std::atoi(args.Get("workers", "32").c_str());
  const int n_max = std::atoi(args.Get("n-max", "10").c_str());
  const int n_jobs = std::atoi(args.Get("jobs", "1").c_str());
  auto text = wormdrag::rpc::ReadText(recording);
  if (!text.ok()) {
    std::fprintf(stderr, "service_bench: --recording K.csv is required (%s)\n", text.status().message().c_str());
    return 2;
  }
  auto ch = grpc::CreateChannel(server, grpc::InsecureChannelCredentials());
  auto jobs = v2::JobService::NewStub(ch);
  v2::SubmitJobRequest req;
  req.mutable_recording1()->set_name("a.csv");
  req.mutable_recording1()->set_content(*text);
  req.mutable_recording2()->set_name("b.csv");
  req.mutable_recording2()->set_content(*text);
  req.mutable_options()->set_n_max(n_max);
  std::vector<int64_t> job_ids;
  for (int j = 0; j < n_jobs; ++j) {
    // Spans differ by a frame or so, so no job reuses another's stored sets (recordings of at least 1 s).
    req.mutable_options()->set_t_max(1.0 - 0.01 * j);
    v2::SubmitJobResponse sub;
    grpc::ClientContext ctx;
    grpc::Status st = jobs->SubmitJob(&ctx, req, &sub);
    if (!st.ok()) {
      std::fprintf(stderr, "submit: %s\n", st.error_message().c_str());
      return 1;
    }
    job_ids.push_back(sub.job_id());
  }
  const int64_t total = n_jobs * static_cast<int64_t>(std::pow(n_max + 1, 4));
  std::atomic<int64_t> leases{0}, sets{0};
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  const auto t0 = std::chrono::steady_clock::now();
  for (int w = 0; w < workers; ++w)
    threads.emplace_back([&, w] {
      // Each simulated worker has its own connection, as separate processes would.
      grpc::ChannelArguments args;
      args.SetInt("grpc.use_local_subchannel_pool", 1);
      auto stub = v2::WorkerService::NewStub(
          grpc::CreateCustomChannel(server, grpc::InsecureChannelCredentials(), args));
      const std::string id = "fake" + std::to_string(w);
      while (!stop) {
        v2::LeaseTaskRequest lr;
        lr.set_worker_id(id);
        lr.set_wait_ms(200);
        v2::LeaseTaskResponse lease;
        grpc::ClientContext ctx;
        if (!stub->LeaseTask(&ctx, lr, &lease).ok() || !lease.has_task()) continue;
        ++leases;
        v2::ReportResultRequest rr;
        rr.set_worker_id(id);
        rr.set_task_id(lease.task().task_id());
        rr.set_lease_id(lease.task().lease_id());
        for (const auto& c : lease.task().sets()) rr.add_values(1 + c.mu_n() + c.mu_t() + c.eta_n() + c.eta_t());
        v2::ReportResultResponse resp;
        grpc::ClientContext rctx;
        if (stub->ReportResult(&rctx, rr, &resp).ok()) sets += lease.task().sets_size();
      }
    });
  // Phase 1 is done when every grid set of every job has been reported.
  while (sets < total) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stop = true;
  for (auto& t : threads) t.join();
  for (int64_t id : job_ids) {
    grpc::ClientContext ctx;
    v2::CancelJobRequest cr;
    cr.set_job_id(id);
    v2::CancelJobResponse r;
    jobs->CancelJob(&ctx, cr, &r);
  }
  std::printf("workers %d, jobs %d, Phase 1 %lld sets in %.3f s: %.0f leases/s (= reports/s), %.0f sets ingested/s\n",
              workers, n_jobs, static_cast<long long>(total), secs, leases / secs, total / secs);
  return 0;
}
