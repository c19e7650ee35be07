#include "server/remote_evaluator.h"

namespace wormdrag::server {

Status RemoteEvaluator::RunTasks(const std::vector<Coefficients>& sets, TaskKind kind,
                                 const EvaluationRequest& request, std::vector<TaskResult>* results) {
  std::vector<TaskSpec> tasks;
  for (size_t first = 0; first < sets.size(); first += static_cast<size_t>(chunk_)) {
    const size_t count = std::min(static_cast<size_t>(chunk_), sets.size() - first);
    TaskSpec t;
    t.id = MakeTaskId(job_, screening_, kind, &sets[first], count);
    t.job = job_;
    t.screening = screening_;
    t.kind = kind;
    t.sets.assign(sets.begin() + static_cast<ptrdiff_t>(first), sets.begin() + static_cast<ptrdiff_t>(first + count));
    tasks.push_back(std::move(t));
  }
  const int64_t total = static_cast<int64_t>(sets.size());
  return scheduler_.Run(job_, std::move(tasks), results, [&](int64_t done) {
    if (request.progress) request.progress(done, total);
  });
}

Status RemoteEvaluator::Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                 const EvaluationRequest& request) {
  e->clear();
  if (sets.empty()) return Status::Ok();
  std::vector<TaskResult> results;
  const TaskKind kind =
      request.objective == Objective::kMeanDistance ? TaskKind::kMeanDistance : TaskKind::kMeanSquaredDistance;
  WORMDRAG_RETURN_IF_ERROR(RunTasks(sets, kind, request, &results));
  e->reserve(sets.size());
  for (const auto& r : results) e->insert(e->end(), r.values.begin(), r.values.end());
  if (e->size() != sets.size()) return Status::Internal("task results do not cover the batch");
  return Status::Ok();
}

Status RemoteEvaluator::EvaluateResiduals(const std::vector<Coefficients>& sets,
                                          std::vector<std::vector<double>>* residuals,
                                          const EvaluationRequest& request) {
  residuals->clear();
  if (sets.empty()) return Status::Ok();
  std::vector<TaskResult> results;
  WORMDRAG_RETURN_IF_ERROR(RunTasks(sets, TaskKind::kResiduals, request, &results));
  for (auto& r : results)
    for (auto& v : r.residuals) residuals->push_back(std::move(v));
  if (residuals->size() != sets.size()) return Status::Internal("task results do not cover the batch");
  return Status::Ok();
}

}  // namespace wormdrag::server
