// The gRPC services of the coordinator: thin translations between the wire
// (proto/wormdrag/v2) and the Coordinator. Every request is authenticated (when a
// token is configured) and validated; errors carry the matching gRPC status.
//
// Each service has its own token. When the worker token differs from the client
// token, a call carrying the other service's token is refused PERMISSION_DENIED: a
// worker's credential (copied to every lab machine) cannot submit, read or cancel
// jobs, and a client's cannot lease tasks or report results.
#pragma once

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "proto/convert.h"
#include "server/coordinator.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace wormdrag::server {

void JobToProto(const JobRecord& j, wormdrag::v2::Job* out);

class JobServiceImpl final : public wormdrag::v2::JobService::Service {
 public:
  // `worker_token`: refused on these calls when it differs from `token`.
  JobServiceImpl(Coordinator& c, std::string token, std::string worker_token = "")
      : c_(c), token_(std::move(token)), worker_token_(std::move(worker_token)) {}
  grpc::Status SubmitJob(grpc::ServerContext*, const wormdrag::v2::SubmitJobRequest*,
                         wormdrag::v2::SubmitJobResponse*) override;
  grpc::Status GetJob(grpc::ServerContext*, const wormdrag::v2::GetJobRequest*, wormdrag::v2::Job*) override;
  grpc::Status ListJobs(grpc::ServerContext*, const wormdrag::v2::ListJobsRequest*,
                        wormdrag::v2::ListJobsResponse*) override;
  grpc::Status CancelJob(grpc::ServerContext*, const wormdrag::v2::CancelJobRequest*,
                         wormdrag::v2::CancelJobResponse*) override;
  grpc::Status WatchJob(grpc::ServerContext*, const wormdrag::v2::WatchJobRequest*,
                        grpc::ServerWriter<wormdrag::v2::JobProgress>*) override;
  grpc::Status GetResults(grpc::ServerContext*, const wormdrag::v2::GetResultsRequest*,
                          wormdrag::v2::GetResultsResponse*) override;
  grpc::Status ExportResults(grpc::ServerContext*, const wormdrag::v2::ExportResultsRequest*,
                             grpc::ServerWriter<wormdrag::v2::ExportChunk>*) override;

 private:
  grpc::Status Auth(const grpc::ServerContext* ctx) const;
  Coordinator& c_;
  std::string token_, worker_token_;
};

class WorkerServiceImpl final : public wormdrag::v2::WorkerService::Service {
 public:
  // `client_token`: refused on these calls when it differs from `token`.
  WorkerServiceImpl(Coordinator& c, std::string token, std::string client_token = "")
      : c_(c), token_(std::move(token)), client_token_(std::move(client_token)) {}
  grpc::Status LeaseTask(grpc::ServerContext*, const wormdrag::v2::LeaseTaskRequest*,
                         wormdrag::v2::LeaseTaskResponse*) override;
  grpc::Status Heartbeat(grpc::ServerContext*, const wormdrag::v2::HeartbeatRequest*,
                         wormdrag::v2::HeartbeatResponse*) override;
  grpc::Status ReportResult(grpc::ServerContext*, const wormdrag::v2::ReportResultRequest*,
                            wormdrag::v2::ReportResultResponse*) override;
  grpc::Status GetDataset(grpc::ServerContext*, const wormdrag::v2::GetDatasetRequest*,
                          wormdrag::v2::GetDatasetResponse*) override;

 private:
  grpc::Status Auth(const grpc::ServerContext* ctx) const;
  Coordinator& c_;
  std::string token_, client_token_;
};

}  // namespace wormdrag::server
