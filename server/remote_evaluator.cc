#include "server/remote_evaluator.h"

#include <algorithm>
#include <array>

namespace wormdrag::server {

std::vector<size_t> TaskSizes(size_t n, int chunk_sets, int workers) {
  std::vector<size_t> sizes;
  if (n == 0) return sizes;
  const size_t lanes = static_cast<size_t>(kLanes);
  const size_t groups = (n + lanes - 1) / lanes;
  const size_t per_task = std::max<size_t>(1, static_cast<size_t>(chunk_sets) / lanes);
  const size_t w = static_cast<size_t>(std::max(1, workers));
  size_t tasks = (groups + per_task - 1) / per_task;
  tasks = std::min(groups, (tasks + w - 1) / w * w);
  const size_t base = groups / tasks, extra = groups % tasks;
  size_t left = n;
  for (size_t i = 0; i < tasks; ++i) {
    const size_t count = std::min(left, (base + (i < extra ? 1 : 0)) * lanes);
    sizes.push_back(count);
    left -= count;
  }
  return sizes;
}

bool SplitByWorm(size_t n, int workers, bool cut) {
  const size_t groups = (n + kLanes - 1) / kLanes;
  return !cut && groups > 0 && groups < static_cast<size_t>(std::max(1, workers));
}

void GroupCuts(RunningCut* const* cuts, size_t count, std::vector<double>* values, std::vector<int32_t>* groups) {
  values->resize(count);
  groups->resize(count);
  for (size_t i = 0; i < count; ++i) {
    (*values)[i] = cuts[i]->value();
    size_t g = 0;
    while (cuts[g] != cuts[i]) ++g;  // the group's first set in the task
    (*groups)[i] = static_cast<int32_t>(g);
  }
}

namespace {

// One worm's share of a lane group, as SimulateWormLanes leaves it.
WormLanes ShareOf(TaskKind kind, TaskResult&& r) {
  WormLanes w;
  w.knots = r.knots;
  for (size_t i = 0; i < r.values.size() && i < static_cast<size_t>(kLanes); ++i)
    (kind == TaskKind::kMeanDistance ? w.sum : w.sum_sq)[i] = r.values[i];
  for (size_t i = 0; i < r.residuals.size() && i < static_cast<size_t>(kLanes); ++i) {
    w.failed[i] = r.residuals[i].empty();
    w.residuals[i] = std::move(r.residuals[i]);
    if (i < r.jacobians.size()) w.jacobian[i] = std::move(r.jacobians[i]);
  }
  return w;
}

}  // namespace

TaskResult CombineWormShares(const PairedPath& pair, TaskKind kind, int count, TaskResult&& a, TaskResult&& b) {
  TaskResult r;
  r.knots_full = a.knots_full + b.knots_full;
  const std::array<WormLanes, 2> worms = {ShareOf(kind, std::move(a)), ShareOf(kind, std::move(b))};
  r.knots = worms[0].knots + worms[1].knots;
  if (kind == TaskKind::kMeanDistance || kind == TaskKind::kMeanSquaredDistance) {
    r.values.resize(static_cast<size_t>(count));
    CombineWormSums(pair, worms, count,
                    kind == TaskKind::kMeanDistance ? Objective::kMeanDistance : Objective::kMeanSquaredDistance,
                    r.values.data());
    return r;
  }
  r.residuals.resize(static_cast<size_t>(count));
  if (kind == TaskKind::kResidualJacobians) r.jacobians.resize(static_cast<size_t>(count));
  CombineWormResiduals(worms, count, r.residuals.data(),
                       kind == TaskKind::kResidualJacobians ? r.jacobians.data() : nullptr);
  return r;
}

TaskSpec RemoteEvaluator::NewTask(TaskKind kind, const std::vector<Coefficients>& sets, size_t first, size_t count,
                                  const std::string& id_suffix) const {
  TaskSpec t;
  t.id = MakeTaskId(job_, screening_, kind, &sets[first], count, id_suffix);
  t.job = job_;
  t.screening = screening_;
  t.kind = kind;
  t.sets.assign(sets.begin() + static_cast<ptrdiff_t>(first), sets.begin() + static_cast<ptrdiff_t>(first + count));
  return t;
}

// A call too small for the workers: one task per lane group and worm, the two shares
// combined as LocalEvaluator combines them.
Status RemoteEvaluator::RunWormShares(const std::vector<Coefficients>& sets, TaskKind kind,
                                      const EvaluationRequest& request, std::vector<TaskResult>* results) {
  const int64_t total = static_cast<int64_t>(sets.size());
  std::vector<TaskSpec> tasks;
  std::vector<int> counts;
  for (size_t first = 0; first < sets.size(); first += kLanes) {
    const size_t count = std::min(sets.size() - first, static_cast<size_t>(kLanes));
    counts.push_back(static_cast<int>(count));
    for (int worm = 1; worm <= 2; ++worm) {
      TaskSpec t = NewTask(kind, sets, first, count, "|worm" + std::to_string(worm));
      t.worm = worm;
      tasks.push_back(std::move(t));
    }
  }
  std::vector<TaskResult> shares;
  WORMDRAG_RETURN_IF_ERROR(scheduler_.Run(job_, std::move(tasks), &shares, [&](int64_t done) {
    if (request.progress) request.progress(done / 2, total);  // every set is in two tasks
  }));
  if (shares.size() != 2 * counts.size()) return Status::Internal("task results do not cover the batch");
  results->clear();
  for (size_t g = 0; g < counts.size(); ++g)
    results->push_back(
        CombineWormShares(*pair_, kind, counts[g], std::move(shares[2 * g]), std::move(shares[2 * g + 1])));
  return Status::Ok();
}

Status RemoteEvaluator::RunTasks(const std::vector<Coefficients>& sets, TaskKind kind, const EvaluationRequest& request,
                                 const RunningCut* cut, std::vector<TaskResult>* results) {
  if (SplitByWorm(sets.size(), scheduler_.ActiveWorkers(), cut != nullptr))
    return RunWormShares(sets, kind, request, results);
  const int64_t total = static_cast<int64_t>(sets.size());
  const bool group_cuts = !request.set_cuts.empty() &&
                          (kind == TaskKind::kMeanDistance || kind == TaskKind::kMeanSquaredDistance);
  std::vector<TaskSpec> tasks;
  size_t first = 0;
  // Jacobian results are five times the residuals alone: smaller tasks.
  const int chunk = kind == TaskKind::kResidualJacobians ? std::max(kLanes, chunk_ / 4 / kLanes * kLanes) : chunk_;
  for (const size_t count : TaskSizes(sets.size(), chunk, scheduler_.ActiveWorkers())) {
    std::string suffix = cut ? "|abandon|phase" + std::to_string(request.phase) : "";
    std::vector<double> cut_values;
    std::vector<int32_t> cut_groups;
    if (group_cuts) {
      GroupCuts(&request.set_cuts[first], count, &cut_values, &cut_groups);
      suffix += "|groupcuts";
      suffix.append(reinterpret_cast<const char*>(cut_values.data()), sizeof(double) * count);
      suffix.append(reinterpret_cast<const char*>(cut_groups.data()), sizeof(int32_t) * count);
    }
    TaskSpec t = NewTask(kind, sets, first, count, suffix);
    if (cut) {
      t.keep = cut->keep();
      t.cut = cut->value();
    }
    t.set_cuts = std::move(cut_values);
    t.set_groups = std::move(cut_groups);
    tasks.push_back(std::move(t));
    first += count;
  }
  return scheduler_.Run(job_, std::move(tasks), results, [&](int64_t done) {
    if (request.progress) request.progress(done, total);
  });
}

Status RemoteEvaluator::Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                 const EvaluationRequest& request) {
  e->clear();
  if (sets.empty()) return Status::Ok();
  std::vector<TaskResult> results;
  const TaskKind kind = request.objective == Objective::kMeanDistance ? TaskKind::kMeanDistance
                                                                      : TaskKind::kMeanSquaredDistance;
  RunningCut* cut = kind == TaskKind::kMeanDistance ? request.cut : nullptr;
  WORMDRAG_RETURN_IF_ERROR(CheckSetCuts(sets, request));
  if (cut && !request.set_cuts.empty()) return Status::InvalidArgument("a call has either a cut or group cuts");
  WORMDRAG_RETURN_IF_ERROR(RunTasks(sets, kind, request, cut, &results));
  e->reserve(sets.size());
  for (const auto& r : results) {
    e->insert(e->end(), r.values.begin(), r.values.end());
    if (request.knots) {
      request.knots->simulated += r.knots;
      request.knots->full += r.knots_full;
    }
  }
  if (e->size() != sets.size()) return Status::Internal("task results do not cover the batch");
  if (cut)
    for (double v : *e) cut->Offer(v);
  for (size_t i = 0; i < request.set_cuts.size() && i < e->size(); ++i) request.set_cuts[i]->Offer((*e)[i]);
  return Status::Ok();
}

Status RemoteEvaluator::EvaluateResiduals(const std::vector<Coefficients>& sets,
                                          std::vector<std::vector<double>>* residuals,
                                          const EvaluationRequest& request) {
  residuals->clear();
  if (sets.empty()) return Status::Ok();
  std::vector<TaskResult> results;
  WORMDRAG_RETURN_IF_ERROR(RunTasks(sets, TaskKind::kResiduals, request, nullptr, &results));
  for (auto& r : results)
    for (auto& v : r.residuals) residuals->push_back(std::move(v));
  if (residuals->size() != sets.size()) return Status::Internal("task results do not cover the batch");
  return Status::Ok();
}

Status RemoteEvaluator::EvaluateResidualJacobians(const std::vector<Coefficients>& sets,
                                                  std::vector<std::vector<double>>* residuals,
                                                  std::vector<std::vector<double>>* jacobians,
                                                  const EvaluationRequest& request) {
  residuals->clear();
  jacobians->clear();
  if (sets.empty()) return Status::Ok();
  std::vector<TaskResult> results;
  WORMDRAG_RETURN_IF_ERROR(RunTasks(sets, TaskKind::kResidualJacobians, request, nullptr, &results));
  for (auto& r : results) {
    for (auto& v : r.residuals) residuals->push_back(std::move(v));
    for (auto& v : r.jacobians) jacobians->push_back(std::move(v));
  }
  if (residuals->size() != sets.size() || jacobians->size() != sets.size())
    return Status::Internal("task results do not cover the batch");
  return Status::Ok();
}

}  // namespace wormdrag::server
