// The gRPC services of the coordinator: thin translations between the wire
// (proto/wormdrag/v1) and the Coordinator. Every request is authenticated (when a
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
#include "wormdrag/v1/jobs.grpc.pb.h"
#include "wormdrag/v1/worker.grpc.pb.h"

namespace wormdrag::server {

void JobToProto(const JobRecord& j, wormdrag::v1::Job* out);

class JobServiceImpl final : public wormdrag::v1::JobService::Service {
 public:
  // `worker_token`: refused on these calls when it differs from `token`.
  JobServiceImpl(Coordinator& c, std::string token, std::string worker_token = "")
      : c_(c), token_(std::move(token)), worker_token_(std::move(worker_token)) {}
  grpc::Status SubmitJob(grpc::ServerContext*, const wormdrag::v1::SubmitJobRequest*,
                         wormdrag::v1::SubmitJobResponse*) override;
  grpc::Status GetJob(grpc::ServerContext*, const wormdrag::v1::GetJobRequest*, wormdrag::v1::Job*) override;
  grpc::Status ListJobs(grpc::ServerContext*, const wormdrag::v1::ListJobsRequest*,
                        wormdrag::v1::ListJobsResponse*) override;
  grpc::Status CancelJob(grpc::ServerContext*, const wormdrag::v1::CancelJobRequest*,
                         wormdrag::v1::CancelJobResponse*) override;
  grpc::Status WatchJob(grpc::ServerContext*, const wormdrag::v1::WatchJobRequest*,
                        grpc::ServerWriter<wormdrag::v1::JobProgress>*) override;
  grpc::Status GetResults(grpc::ServerContext*, const wormdrag::v1::GetResultsRequest*,
                          wormdrag::v1::GetResultsResponse*) override;
  grpc::Status ExportResults(grpc::ServerContext*, const wormdrag::v1::ExportResultsRequest*,
                             grpc::ServerWriter<wormdrag::v1::ExportChunk>*) override;

 private:
  grpc::Status Auth(const grpc::ServerContext* ctx) const;
  Coordinator& c_;
  std::string token_, worker_token_;
};

class WorkerServiceImpl final : public wormdrag::v1::WorkerService::Service {
 public:
  // `client_token`: refused on these calls when it differs from `token`.
  WorkerServiceImpl(Coordinator& c, std::string token, std::string client_token = "")
      : c_(c), token_(std::move(token)), client_token_(std::move(client_token)) {}
  grpc::Status LeaseTask(grpc::ServerContext*, const wormdrag::v1::LeaseTaskRequest*,
                         wormdrag::v1::LeaseTaskResponse*) override;
  grpc::Status Heartbeat(grpc::ServerContext*, const wormdrag::v1::HeartbeatRequest*,
                         wormdrag::v1::HeartbeatResponse*) override;
  grpc::Status ReportResult(grpc::ServerContext*, const wormdrag::v1::ReportResultRequest*,
                            wormdrag::v1::ReportResultResponse*) override;
  grpc::Status GetDataset(grpc::ServerContext*, const wormdrag::v1::GetDatasetRequest*,
                          wormdrag::v1::GetDatasetResponse*) override;

 private:
  grpc::Status Auth(const grpc::ServerContext* ctx) const;
  Coordinator& c_;
  std::string token_, client_token_;
};

}  // namespace wormdrag::server
