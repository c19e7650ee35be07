#include "server/services.h"

#include <cmath>
#include <cstdio>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "core/common/guard.h"
#include "core/jobs/bootstrap_run.h"
#include "core/jobs/diagnose_job.h"

#include "proto/result_convert.h"
#include "proto/rpc_util.h"

namespace wormdrag::server {

namespace v2 = wormdrag::v2;
using grpc::ServerContext;
using rpc::ToGrpc;

namespace {

grpc::Status Invalid(const std::string& m) {
  return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, m);
}

v2::JobState StateToProto(JobState s) {
  switch (s) {
    case JobState::kQueued:
      return v2::JOB_STATE_QUEUED;
    case JobState::kRunning:
      return v2::JOB_STATE_RUNNING;
    case JobState::kDone:
      return v2::JOB_STATE_DONE;
    case JobState::kFailed:
      return v2::JOB_STATE_FAILED;
    case JobState::kCancelled:
      return v2::JOB_STATE_CANCELLED;
  }
  return v2::JOB_STATE_UNSPECIFIED;
}

void EvalToProto(const EvaluationRecord& r, v2::Evaluation* e) {
  e->set_phase(r.phase);
  e->set_mu_n(r.set.mu_n);
  e->set_mu_t(r.set.mu_t);
  e->set_eta_n(r.set.eta_n);
  e->set_eta_t(r.set.eta_t);
  e->set_e(r.e);
}

bool Terminal(JobState s) {
  return s == JobState::kDone || s == JobState::kFailed || s == JobState::kCancelled;
}

grpc::Status CheckJobId(int64_t id) {
  if (id <= 0) return Invalid("job_id must be a positive job number, got " + std::to_string(id));
  return grpc::Status::OK;
}

// The token check of one service: `other`, the other service's token, is refused
// by name when it differs from `own` (even when this service is open), then `own`
// is required.
grpc::Status CheckServiceToken(const ServerContext* ctx, const std::string& own, const std::string& other,
                               const char* service, const char* other_role) {
  if (!other.empty() && other != own && rpc::CheckToken(ctx, other).ok())
    return grpc::Status(
        grpc::StatusCode::PERMISSION_DENIED,
        std::string("the ") + other_role + " token is not accepted by " + service + ": it needs its own token");
  return rpc::CheckToken(ctx, own);
}

}  // namespace

void JobToProto(const JobRecord& j, v2::Job* out) {
  out->set_id(j.id);
  out->set_state(StateToProto(j.state));
  out->set_created_at(j.created_at);
  out->set_updated_at(j.updated_at);
  for (int k = 0; k < 2; ++k) {
    out->add_dataset_names(j.dataset_names[k]);
    out->add_dataset_hashes(j.dataset_hashes[k]);
  }
  // Options the store cannot read were refused when the job was made; a job whose text
  // fails anyway is shown without them rather than not at all.
  if (Status st = rpc::SetJobOptions(j.options_json, j.kind == "diagnose", out); !st.ok())
    spdlog::warn("event=job_options_unreadable job={} error=\"{}\"", j.id, st.message());
  out->set_phase(j.phase);
  out->set_sets_done(j.sets_done);
  out->set_sets_total(j.sets_total);
  out->set_best_e(j.best_e);
  out->set_error(j.error);
  out->set_kind(j.kind);
}

// ---------------------------------------------------------------- JobService

grpc::Status JobServiceImpl::Auth(const ServerContext* ctx) const {
  return CheckServiceToken(ctx, token_, worker_token_, "JobService (submit, jobs, results, cancel)", "worker");
}

grpc::Status JobServiceImpl::SubmitJob(ServerContext* ctx, const v2::SubmitJobRequest* req,
                                       v2::SubmitJobResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  std::array<JobInput, 2> in;
  const v2::Recording* recs[2] = {&req->recording1(), &req->recording2()};
  for (int k = 0; k < 2; ++k) {
    if (!(k == 0 ? req->has_recording1() : req->has_recording2()) || recs[k]->content().empty())
      return Invalid("recording" + std::to_string(k + 1) + " is missing or empty: a job needs two recordings");
    in[k].name = recs[k]->name().empty() ? "recording" + std::to_string(k + 1) : recs[k]->name();
    in[k].content = recs[k]->content();
  }
  bool reused = false;
  Result<int64_t> id = Status::Internal("unset");
  if (req->has_diagnose()) {
    if (req->has_options()) return Invalid("a job is an estimation (options) or a diagnosis (diagnose), not both");
    if (req->reuse()) return Invalid("reuse applies to estimation jobs only");
  }
  // Validation parses untrusted input: nothing it throws may reach gRPC's thread.
  const Status guarded = RunGuarded("submission", [&]() -> Status {
    if (req->has_diagnose()) {
      auto options = rpc::DiagnoseOptionsFromProto(req->diagnose());
      if (!options.ok()) return options.status();
      id = c_.SubmitDiagnosis(in, *options);
    } else {
      auto options = rpc::OptionsFromProto(req->options());
      if (!options.ok()) return options.status();
      id = c_.Submit(in, *options, req->reuse(), &reused);
    }
    return id.status();
  });
  if (!guarded.ok()) id = guarded;
  if (!id.ok()) {
    spdlog::info("event=submit_rejected code={} error=\"{}\"", CodeName(id.status().code()), id.status().message());
    return ToGrpc(id.status());
  }
  resp->set_job_id(*id);
  resp->set_reused(reused);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::GetJob(ServerContext* ctx, const v2::GetJobRequest* req, v2::Job* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (auto v = CheckJobId(req->job_id()); !v.ok()) return v;
  auto p = c_.Progress(req->job_id());
  if (!p.ok()) return ToGrpc(p.status());
  JobToProto(p->job, resp);
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::ListJobs(ServerContext* ctx, const v2::ListJobsRequest* req, v2::ListJobsResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (req->limit() < 0) return Invalid("limit must be >= 0 (0 = all)");
  auto jobs = c_.store().ListJobs(req->limit());
  if (!jobs.ok()) return ToGrpc(jobs.status());
  for (const auto& j : *jobs) JobToProto(j, resp->add_jobs());
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::CancelJob(ServerContext* ctx, const v2::CancelJobRequest* req,
                                       v2::CancelJobResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (auto v = CheckJobId(req->job_id()); !v.ok()) return v;
  auto s = c_.Cancel(req->job_id());
  if (!s.ok()) return ToGrpc(s.status());
  resp->set_state(StateToProto(*s));
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::WatchJob(ServerContext* ctx, const v2::WatchJobRequest* req,
                                      grpc::ServerWriter<v2::JobProgress>* writer) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (auto v = CheckJobId(req->job_id()); !v.ok()) return v;
  uint64_t version = 0;
  auto last_sent = std::chrono::steady_clock::now() - std::chrono::seconds(10);
  for (;;) {
    auto p = c_.Progress(req->job_id());
    if (!p.ok()) return ToGrpc(p.status());
    const auto now = std::chrono::steady_clock::now();
    const bool end = Terminal(p->job.state);
    if (end || now - last_sent >= std::chrono::milliseconds(250)) {
      v2::JobProgress m;
      JobToProto(p->job, m.mutable_job());
      m.set_tasks_queued(p->tasks.queued);
      m.set_tasks_leased(p->tasks.leased);
      m.set_tasks_done(p->tasks.done);
      m.set_workers(p->workers);
      m.set_sets_per_second(p->sets_per_second);
      m.set_eta_seconds(p->eta_seconds);
      if (!writer->Write(m)) return grpc::Status::OK;  // the client went away
      last_sent = now;
    }
    if (end) return grpc::Status::OK;
    if (ctx->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "watch cancelled");
    c_.WaitForChange(&version, std::chrono::milliseconds(1000));
  }
}

grpc::Status JobServiceImpl::GetResults(ServerContext* ctx, const v2::GetResultsRequest* req,
                                        v2::GetResultsResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (auto v = CheckJobId(req->job_id()); !v.ok()) return v;
  if (req->top() < 0 || req->top() > 100000) return Invalid("top must be between 0 and 100000");
  auto job = c_.store().GetJob(req->job_id());
  if (!job.ok()) return ToGrpc(job.status());
  JobToProto(*job, resp->mutable_job());
  if (!job->result_json.empty()) {
    Status st = rpc::SetJobResult(job->kind, job->result_json, resp);
    if (!st.ok()) return ToGrpc(Status::Internal("job " + std::to_string(job->id) + ": " + st.message()));
  }
  for (int phase : {1, 2}) {
    auto s = c_.store().Survivors(req->job_id(), phase);
    if (!s.ok()) return ToGrpc(s.status());
    for (const auto& r : *s) EvalToProto(r, phase == 1 ? resp->add_survivors1() : resp->add_survivors2());
  }
  if (req->top() > 0) {
    auto top = c_.store().Evaluations(req->job_id(), 1, req->top());
    if (!top.ok()) return ToGrpc(top.status());
    for (const auto& r : *top) EvalToProto(r, resp->add_top());
  }
  return grpc::Status::OK;
}

grpc::Status JobServiceImpl::ExportResults(ServerContext* ctx, const v2::ExportResultsRequest* req,
                                           grpc::ServerWriter<v2::ExportChunk>* writer) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (auto v = CheckJobId(req->job_id()); !v.ok()) return v;
  auto job = c_.store().GetJob(req->job_id());
  if (!job.ok()) return ToGrpc(job.status());
  auto all = c_.store().Evaluations(req->job_id(), 0, 0);
  if (!all.ok()) return ToGrpc(all.status());
  std::string buf = "phase,mu_n,mu_t,eta_n,eta_t,e\n";
  char line[200];
  for (const auto& r : *all) {
    std::snprintf(line, sizeof line, "%d,%.17g,%.17g,%.17g,%.17g,%.17g\n", r.phase, r.set.mu_n, r.set.mu_t, r.set.eta_n,
                  r.set.eta_t, r.e);
    buf += line;
    if (buf.size() > (1 << 20)) {
      v2::ExportChunk c;
      c.set_data(std::move(buf));
      if (!writer->Write(c)) return grpc::Status::OK;
      buf.clear();
    }
  }
  if (!buf.empty()) {
    v2::ExportChunk c;
    c.set_data(std::move(buf));
    writer->Write(c);
  }
  return grpc::Status::OK;
}

// ------------------------------------------------------------- WorkerService

grpc::Status WorkerServiceImpl::Auth(const ServerContext* ctx) const {
  return CheckServiceToken(ctx, token_, client_token_, "WorkerService (lease, heartbeat, report)", "client");
}

namespace {

// A task's payload on the wire: the scheduler keeps it as the JSON its id is made of,
// and it travels typed.
Status SetPayload(const TaskSpec& spec, v2::Task* task) {
  if (spec.kind == TaskKind::kBootstrapReplicate) {
    auto r = ReplicateTaskFromJson(spec.payload);
    if (!r.ok()) return r.status();
    rpc::ReplicateTaskToProto(*r, task->mutable_replicate());
  } else if (spec.kind == TaskKind::kDiagnoseFit) {
    auto f = FitTaskFromJson(spec.payload);
    if (!f.ok()) return f.status();
    rpc::FitTaskToProto(*f, task->mutable_fit());
  } else if (!spec.payload.empty()) {
    return Status::Internal("a task of kind " + std::to_string(static_cast<int>(spec.kind)) + " has a payload");
  }
  return Status::Ok();
}

}  // namespace

grpc::Status WorkerServiceImpl::LeaseTask(ServerContext* ctx, const v2::LeaseTaskRequest* req,
                                          v2::LeaseTaskResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (req->worker_id().empty() || req->worker_id().size() > 200)
    return Invalid("worker_id must be 1 to 200 characters");
  if (req->wait_ms() < 0 || req->wait_ms() > 10000) return Invalid("wait_ms must be between 0 and 10000");
  if (std::string why; c_.scheduler().WorkerQuarantined(req->worker_id(), &why))
    return grpc::Status(grpc::StatusCode::PERMISSION_DENIED,
                        "worker " + req->worker_id() + " is quarantined: " + why + "; it gets no more tasks");
  LeasedTask t;
  c_.activity().Polled(req->worker_id(), req->threads());
  if (!c_.scheduler().Lease(req->worker_id(), std::chrono::milliseconds(req->wait_ms()), &t)) {
    return grpc::Status::OK;  // no task field: nothing to do now
  }
  c_.activity().Leased(req->worker_id(), t.spec.id, t.spec.units());
  v2::Task* task = resp->mutable_task();
  task->set_task_id(t.spec.id);
  task->set_job_id(t.spec.job);
  for (int k = 0; k < 2; ++k) {
    task->add_dataset_hashes(t.job.dataset_hashes[k]);
    task->add_dataset_names(t.job.dataset_names[k]);
  }
  // The job runner read these options before it made the task, so they convert.
  if (Status st = rpc::SetJobOptions(t.job.options_json, t.spec.kind == TaskKind::kDiagnoseFit, task); !st.ok()) {
    spdlog::error("event=task_options_unreadable task={} error=\"{}\"", t.spec.id, st.message());
    return grpc::Status(grpc::StatusCode::INTERNAL, "the task's job options do not convert: " + st.ToString());
  }
  task->set_lease_seconds(static_cast<int>(c_.scheduler().lease_seconds()));
  task->set_screening(t.spec.screening);
  task->set_kind(static_cast<v2::TaskKind>(static_cast<int>(t.spec.kind)));
  if (Status st = SetPayload(t.spec, task); !st.ok()) {
    spdlog::error("event=task_payload_unreadable task={} error=\"{}\"", t.spec.id, st.message());
    return grpc::Status(grpc::StatusCode::INTERNAL, "the task's payload does not convert: " + st.ToString());
  }
  task->set_lease_id(t.lease_id);
  if (t.spec.keep > 0) {
    task->set_keep(t.spec.keep);
    task->set_cut(t.spec.cut);
  }
  task->set_worm(t.spec.worm);
  *task->mutable_set_cuts() = {t.spec.set_cuts.begin(), t.spec.set_cuts.end()};
  *task->mutable_set_groups() = {t.spec.set_groups.begin(), t.spec.set_groups.end()};
  for (const auto& s : t.spec.sets) {
    auto* c = task->add_sets();
    c->set_mu_n(s.mu_n);
    c->set_mu_t(s.mu_t);
    c->set_eta_n(s.eta_n);
    c->set_eta_t(s.eta_t);
  }
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::Heartbeat(ServerContext* ctx, const v2::HeartbeatRequest* req,
                                          v2::HeartbeatResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (req->worker_id().empty()) return Invalid("worker_id is empty");
  std::vector<std::string> ids(req->task_ids().begin(), req->task_ids().end()), cancelled;
  c_.scheduler().Heartbeat(req->worker_id(), ids, &cancelled);
  c_.activity().Heartbeat(req->worker_id());
  for (auto& id : cancelled) resp->add_cancelled_task_ids(id);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::ReportResult(ServerContext* ctx, const v2::ReportResultRequest* req,
                                             v2::ReportResultResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  if (req->worker_id().empty()) return Invalid("worker_id is empty");
  if (req->task_id().empty()) return Invalid("task_id is empty");
  if (req->knots() < 0 || req->knots_full() < 0) return Invalid("knot counts must be >= 0");
  TaskResult r;
  r.values.assign(req->values().begin(), req->values().end());
  for (const auto& v : req->residuals()) {
    r.residuals.emplace_back(v.values().begin(), v.values().end());
    r.jacobians.emplace_back(v.jacobian().begin(), v.jacobian().end());
  }
  r.knots = req->knots();
  r.knots_full = req->knots_full();
  r.worm = req->worm();
  const int64_t units = static_cast<int64_t>(r.residuals.empty() ? r.values.size() : r.residuals.size());
  bool duplicate = false;
  Status st = c_.scheduler().Report(req->worker_id(), req->task_id(), req->lease_id(), std::move(r), req->error(),
                                    &duplicate);
  if (!st.ok()) return ToGrpc(st);
  if (!duplicate) c_.activity().Reported(req->worker_id(), req->task_id(), !req->error().empty(), units);
  resp->set_duplicate(duplicate);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::GetDataset(ServerContext* ctx, const v2::GetDatasetRequest* req,
                                           v2::GetDatasetResponse* resp) {
  if (auto a = Auth(ctx); !a.ok()) return a;
  const std::string& h = req->hash();
  bool hex = h.size() == 64;
  for (char ch : h) hex = hex && ((ch >= '0' && ch <= '9') || (ch >= 'a' && ch <= 'f'));
  if (!hex) return Invalid("dataset hash must be 64 lower-case hex digits (SHA-256)");
  auto d = c_.store().GetDataset(h);
  if (!d.ok()) return ToGrpc(d.status());
  resp->set_hash(d->hash);
  resp->set_name(d->name);
  resp->set_content(d->content);
  return grpc::Status::OK;
}

}  // namespace wormdrag::server
