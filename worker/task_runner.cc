#include "worker/task_runner.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "core/common/guard.h"
#include "core/diagnose/diagnosis.h"
#include "core/io/kinematics.h"
#include "core/jobs/bootstrap_run.h"
#include "core/jobs/diagnose_job.h"
#include "proto/convert.h"

namespace wormdrag::worker {
namespace {

Status NeedsTwoDatasets(const v2::Task& t) {
  if (t.dataset_hashes_size() != 2 || t.dataset_names_size() != 2)
    return Status::InvalidArgument("task names " + std::to_string(t.dataset_hashes_size()) + " datasets, not 2");
  return Status::Ok();
}

// An estimation task's options (every field is set on the wire).
Result<JobOptions> EstimateOptionsOf(const v2::Task& t) {
  if (!t.has_estimate_options()) return Status::InvalidArgument("the task carries no estimation options");
  return rpc::OptionsFromProto(t.estimate_options());
}

Result<diagnose::DiagnoseOptions> DiagnoseOptionsOf(const v2::Task& t) {
  WORMDRAG_RETURN_IF_ERROR(NeedsTwoDatasets(t));
  if (!t.has_diagnose_options()) return Status::InvalidArgument("the diagnosis task carries no diagnosis options");
  return rpc::DiagnoseOptionsFromProto(t.diagnose_options());
}

// The λ scale a task's data are smoothed with: 1 except for the bootstrap's
// smoothing check (a malformed payload is reported by the task itself).
double SmoothingScale(const v2::Task& t) {
  if (t.kind() != v2::TASK_KIND_BOOTSTRAP_REPLICATE) return 1;
  auto task = rpc::ReplicateTaskFromProto(t.replicate());
  return task.ok() && task->refit_data ? task->smoothing_scale : 1;
}

// The request's set cuts from Task.set_cuts and set_groups (none when both are empty):
// `groups` holds each group's cut, at the index of the group's first set.
Status GroupCutsOf(const v2::Task& t, std::vector<std::unique_ptr<RunningCut>>* groups,
                   std::vector<RunningCut*>* cuts) {
  const int n = t.sets_size();
  if (t.set_cuts_size() == 0 && t.set_groups_size() == 0) return Status::Ok();
  if (t.set_cuts_size() != n || t.set_groups_size() != n)
    return Status::InvalidArgument("task " + t.task_id() + " has " + std::to_string(t.set_cuts_size()) +
                                   " set cuts and " + std::to_string(t.set_groups_size()) + " set groups for " +
                                   std::to_string(n) + " sets");
  if (t.keep() > 0) return Status::InvalidArgument("task " + t.task_id() + " has both a cut and set cuts");
  for (int i = 0; i < n; ++i) {
    const int g = t.set_groups(i);
    if (g < 0 || g > i || std::isnan(t.set_cuts(i)))
      return Status::InvalidArgument("task " + t.task_id() + ": set " + std::to_string(i) + " has group " +
                                     std::to_string(g) + " and cut " + std::to_string(t.set_cuts(i)) +
                                     " (a group is an earlier or the same set; a cut is a number)");
    auto& cut = (*groups)[static_cast<size_t>(g)];
    if (!cut) cut = std::make_unique<RunningCut>(1, t.set_cuts(g));
    cuts->push_back(cut.get());
  }
  return Status::Ok();
}

}  // namespace

void TaskRunner::Run(const v2::Task& t, v2::ReportResultRequest* rep) {
  // The task's boundary: whatever the task's inputs make the code throw becomes the
  // task's error report instead of killing this worker (and, retried, every other).
  const Status st = RunGuarded("task " + t.task_id(), [&] { return RunTask(t, rep); });
  if (!st.ok()) {
    rep->clear_values();
    rep->clear_residuals();
    rep->set_error(st.ToString());
  }
}

Status TaskRunner::RunTask(const v2::Task& t, v2::ReportResultRequest* rep) {
  if (t.kind() == v2::TASK_KIND_DIAGNOSE_FIT) return RunFit(t, rep);
  auto pair = GetPair(t, SmoothingScale(t));
  if (!pair.ok()) return pair.status();
  if (t.kind() != v2::TASK_KIND_BOOTSTRAP_REPLICATE) return RunSets(t, *pair, rep);
  // A refit is one Phase 3 from the estimate on the replicate's own data.
  auto task = rpc::ReplicateTaskFromProto(t.replicate());
  if (!task.ok()) return task.status();
  auto options = EstimateOptionsOf(t);
  if (!options.ok()) return options.status();
  const std::vector<double> v = RunReplicateTask(*(*pair)->pair, *task, *options, threads_);
  *rep->mutable_values() = {v.begin(), v.end()};
  return Status::Ok();
}

Status TaskRunner::RunSets(const v2::Task& t, Pair* pair, v2::ReportResultRequest* rep) {
  std::vector<Coefficients> sets;
  sets.reserve(t.sets_size());
  for (const auto& c : t.sets()) sets.push_back({c.mu_n(), c.mu_t(), c.eta_n(), c.eta_t()});
  LocalEvaluator& ev = *pair->evaluator;
  if (t.worm() != 0) return RunWormShare(t, sets, ev, rep);
  if (t.kind() == v2::TASK_KIND_RESIDUALS) {
    std::vector<std::vector<double>> r;
    WORMDRAG_RETURN_IF_ERROR(ev.EvaluateResiduals(sets, &r));
    for (auto& v : r) *rep->add_residuals()->mutable_values() = {v.begin(), v.end()};
    return Status::Ok();
  }
  if (t.kind() == v2::TASK_KIND_RESIDUAL_JACOBIANS) {
    std::vector<std::vector<double>> r, jac;
    WORMDRAG_RETURN_IF_ERROR(ev.EvaluateResidualJacobians(sets, &r, &jac));
    for (size_t i = 0; i < r.size(); ++i) {
      v2::Residuals* out = rep->add_residuals();
      *out->mutable_values() = {r[i].begin(), r[i].end()};
      *out->mutable_jacobian() = {jac[i].begin(), jac[i].end()};
    }
    return Status::Ok();
  }
  if (t.kind() != v2::TASK_KIND_MEAN_DISTANCE && t.kind() != v2::TASK_KIND_MEAN_SQUARED_DISTANCE)
    return Status::InvalidArgument("unknown task kind " + std::to_string(static_cast<int>(t.kind())));
  EvaluationRequest req;
  req.objective = t.kind() == v2::TASK_KIND_MEAN_DISTANCE ? Objective::kMeanDistance : Objective::kMeanSquaredDistance;
  // Early abandoning: the coordinator's cut, tightened by this task's own E.
  std::optional<RunningCut> cut;
  if (t.keep() > 0) cut.emplace(t.keep(), t.cut());
  req.cut = cut ? &*cut : nullptr;
  // Group cuts: one running cut of keep 1 per group, tightened by the group's own values.
  std::vector<std::unique_ptr<RunningCut>> groups(sets.size());
  WORMDRAG_RETURN_IF_ERROR(GroupCutsOf(t, &groups, &req.set_cuts));
  KnotCount knots;
  req.knots = &knots;
  std::vector<double> e;
  WORMDRAG_RETURN_IF_ERROR(ev.Evaluate(sets, &e, req));
  *rep->mutable_values() = {e.begin(), e.end()};
  rep->set_knots(knots.simulated);
  rep->set_knots_full(knots.full);
  return Status::Ok();
}

// One worm's share of a call split by worm (Task.worm): per set, that worm's distance
// sum (of distances, or of squares) or its residual rows; the coordinator combines the
// two shares as LocalEvaluator does.
Status TaskRunner::RunWormShare(const v2::Task& t, const std::vector<Coefficients>& sets, LocalEvaluator& ev,
                                v2::ReportResultRequest* rep) {
  if (t.worm() != 1 && t.worm() != 2)
    return Status::InvalidArgument("task worm " + std::to_string(t.worm()) + " is not 0, 1 or 2");
  if (t.keep() > 0 || t.set_cuts_size() > 0) return Status::InvalidArgument("a worm's share carries no cut");
  LaneOutput what;
  switch (t.kind()) {
    case v2::TASK_KIND_MEAN_DISTANCE:
    case v2::TASK_KIND_MEAN_SQUARED_DISTANCE:
      what = LaneOutput::kSums;
      break;
    case v2::TASK_KIND_RESIDUALS:
      what = LaneOutput::kResiduals;
      break;
    case v2::TASK_KIND_RESIDUAL_JACOBIANS:
      what = LaneOutput::kJacobians;
      break;
    default:
      return Status::InvalidArgument("task kind " + std::to_string(static_cast<int>(t.kind())) +
                                     " cannot be split by worm");
  }
  std::vector<WormLanes> chunks;
  ev.EvaluateWorm(sets, t.worm() - 1, what, &chunks);
  int64_t knots = 0;
  for (const WormLanes& c : chunks) knots += c.knots;
  for (size_t i = 0; i < sets.size(); ++i) {
    const WormLanes& c = chunks[i / kLanes];
    const size_t lane = i % kLanes;
    if (what == LaneOutput::kSums) {
      rep->add_values(t.kind() == v2::TASK_KIND_MEAN_DISTANCE ? c.sum[lane] : c.sum_sq[lane]);
      continue;
    }
    v2::Residuals* out = rep->add_residuals();  // empty: the run failed
    if (c.failed[lane]) continue;
    *out->mutable_values() = {c.residuals[lane].begin(), c.residuals[lane].end()};
    *out->mutable_jacobian() = {c.jacobian[lane].begin(), c.jacobian[lane].end()};
  }
  rep->set_knots(knots);
  rep->set_knots_full(knots);
  rep->set_worm(t.worm());
  return Status::Ok();
}

// `lambda_scale` scales the shape smoothing's λ (the bootstrap's smoothing check).
Result<TaskRunner::Pair*> TaskRunner::GetPair(const v2::Task& t, double lambda_scale) {
  WORMDRAG_RETURN_IF_ERROR(NeedsTwoDatasets(t));
  auto options = EstimateOptionsOf(t);
  if (!options.ok()) return options.status();
  // The screening and the accurate pair share their smoothed recordings.
  const std::string data_key = t.dataset_hashes(0) + "|" + t.dataset_hashes(1) + "|" + options->ToJson() + "|" +
                               std::to_string(lambda_scale);
  const std::string key = data_key + "|" + (t.screening() ? "s" : "a");
  if (Pair* p = pairs_.Find(key)) return p;
  options->spline.lambda_scale = lambda_scale;
  WORMDRAG_RETURN_IF_ERROR(options->spline.Validate());
  const EvaluationOptions eval = t.screening() ? options->estimate.ScreeningEval() : options->estimate.eval;
  const std::array<std::string, 2> names = {t.dataset_names(0), t.dataset_names(1)};
  const std::array<Kinematics, 2>* k = recordings_.Find(data_key);
  if (!k) {
    std::array<Kinematics, 2> smoothed;
    for (int j = 0; j < 2; ++j) {
      auto content = fetch_(t.dataset_hashes(j), names[j]);
      if (!content.ok()) return content.status();
      auto rec = PrepareRecording(names[j], *content, *options);
      if (!rec.ok()) return rec.status();
      smoothed[j] = std::move(*rec);
    }
    k = recordings_.Put(data_key, std::move(smoothed));
  }
  auto pair = PairedPath::Create(*k, names, eval);
  if (!pair.ok()) return pair.status();
  Pair p;
  p.pair = *pair;
  p.evaluator = std::make_unique<LocalEvaluator>(*pair, threads_);
  return pairs_.Put(key, std::move(p));
}

// A diagnosis fit: its data (the job's recordings, or a noise-only replicate made
// from them) is rebuilt once per (job options, datasets, replicate) and kept.
Status TaskRunner::RunFit(const v2::Task& t, v2::ReportResultRequest* rep) {
  auto options = DiagnoseOptionsOf(t);
  if (!options.ok()) return options.status();
  auto task = rpc::FitTaskFromProto(t.fit());
  if (!task.ok()) return task.status();
  char null_key[160];
  std::snprintf(null_key, sizeof null_key, "|%d|%.17g|%.17g|%.17g|%.17g|%.17g", task->replicate, task->null_base.mu_n,
                task->null_base.mu_t, task->null_base.eta_n, task->null_base.eta_t, task->null_sigma);
  const std::string key = t.dataset_hashes(0) + "|" + t.dataset_hashes(1) + "|" + DiagnoseOptionsToJson(*options) +
                          null_key;
  const diagnose::EffectData* data = fit_data_.Find(key);
  if (!data) {
    std::array<Kinematics, 2> k;
    for (int j = 0; j < 2; ++j) {
      auto content = fetch_(t.dataset_hashes(j), t.dataset_names(j));
      if (!content.ok()) return content.status();
      auto rec = ParseKinematics(*content, t.dataset_names(j));
      if (!rec.ok()) return rec.status();
      k[j] = std::move(*rec);
    }
    auto d = diagnose::FitTaskData(k, *options, task->replicate, task->null_base, task->null_sigma);
    if (!d.ok()) return d.status();
    data = fit_data_.Put(key, std::move(*d));
  }
  task->spec.threads = threads_;
  auto fit = diagnose::FitModel(*data, task->spec);
  if (!fit.ok()) return fit.status();
  const std::vector<double> v = FitOutcomeToValues(*fit);
  *rep->mutable_values() = {v.begin(), v.end()};
  return Status::Ok();
}

}  // namespace wormdrag::worker
