// The coordinator's BatchEvaluator: each Evaluate, EvaluateResiduals or
// EvaluateResidualJacobians call becomes tasks leased to workers (TaskSizes); the call
// blocks until every result is in, the job is cancelled, or a task is quarantined.
//
// Task ids are content-addressed: hash(job, level, kind, the task's sets). A
// restarted coordinator replays RunEstimateJob; calls already stored are answered by
// StoredEvaluator and never reach here, so a call sequence number would differ
// between runs while the content of the remaining calls does not. Every task is made
// of whole lane groups counted from the start of the call, so every set is simulated
// in exactly the same SIMD lane group as by the embedded LocalEvaluator: results are
// bit-identical to an embedded run, however the call was split. The split follows the
// number of connected workers, so a coordinator restarted with a different number may
// cut the interrupted call differently and recompute its finished tasks (to the same
// values); earlier Phase 1–2 calls are answered by StoredEvaluator.
//
// Early abandoning: with a request cut, each task carries the phase's cut at the time
// of the call and how many sets the phase keeps; workers abandon against it (and
// against what their own task teaches them), and the call's exact E tighten the cut
// for the next call. Such a task's id also covers the phase: its abandoned sets are
// proven out for that phase only. A stored result reused after a restart stays valid,
// since a cut of the phase only ever proves what the final one would.
//
// Group cuts (EvaluationRequest::set_cuts, Phase 3's scale rays, where only each ray's
// best set matters): each task carries its sets' group cuts at the time of the call and
// which sets share a group; workers abandon a set proven above its group's cut (or above
// the best of its group they completed), and the call's exact values tighten the cuts.
// The cut values are part of the task's id, so a stored result is reused only by a
// call with the same cuts. A call split by worm ignores its group cuts (exact values).
//
// Residual Jacobians (Phase 3's exact Gauss–Newton model) travel with their residuals
// (TASK_KIND_RESIDUAL_JACOBIANS), computed by the workers' LocalEvaluator, so Phase 3
// through the coordinator takes the same steps as embedded. Such a task holds at most
// a quarter of `chunk_sets` sets (at least one lane group): a set's Jacobian is four
// times its residuals (~0.6 MB for 2 × 5 s at 300 fps), and a report must stay under
// the coordinator's message limit. Workers older than this kind fail such tasks
// ("unknown task kind"), so workers are upgraded with the coordinator.
//
// Split by worm: a call without a cut whose lane groups are fewer than the connected
// workers (Phase 3's steps and line searches, of one to a few sets) would leave workers
// idle, so each lane group becomes two tasks, one per worm (Task.worm), and the two
// shares are combined here by the functions LocalEvaluator combines them with
// (CombineWormSums, CombineWormResiduals): the same bits as one task.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/estimate/paired_path.h"
#include "server/scheduler.h"

namespace wormdrag::server {

// How one call of `n` sets is cut into tasks, as the number of sets of each, in queue
// order. Every task is whole lane groups (kLanes sets; only the last may be partial)
// and at most `chunk_sets` sets. The number of tasks is rounded up to a multiple of
// `workers` (while there are groups to share) and the groups are dealt out evenly,
// larger tasks first: the small dependent batches of Phase 3 (e.g. 99 sets) would
// otherwise leave one worker a full chunk more than the others on every round.
std::vector<size_t> TaskSizes(size_t n, int chunk_sets, int workers);
// Whether a call of `n` sets, with or without a cut, is split by worm (see above).
bool SplitByWorm(size_t n, int workers, bool cut);

// A task's group cuts (TaskSpec::set_cuts, set_groups) from a call's cuts of its
// `count` sets: each set's cut value now, and the index of the first of the task's sets
// that shares its cut.
void GroupCuts(RunningCut* const* cuts, size_t count, std::vector<double>* values, std::vector<int32_t>* groups);
// A lane group's result (`count` ≤ kLanes sets of task kind `kind`) from the results of
// its worm-1 and worm-2 tasks, combined as LocalEvaluator combines a batch's two worms.
TaskResult CombineWormShares(const PairedPath& pair, TaskKind kind, int count, TaskResult&& worm1, TaskResult&& worm2);

class RemoteEvaluator : public BatchEvaluator {
 public:
  // `pair` is the job's paired path at this evaluator's level (its scored count
  // combines the shares of a call split by worm).
  RemoteEvaluator(Scheduler& scheduler, std::shared_ptr<const PairedPath> pair, int64_t job, bool screening,
                  int chunk_sets, int parallelism)
      : scheduler_(scheduler),
        pair_(std::move(pair)),
        job_(job),
        screening_(screening),
        chunk_(chunk_sets),
        parallelism_(parallelism) {}
  Status Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                  const EvaluationRequest& request = {}) override;
  Status EvaluateResiduals(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                           const EvaluationRequest& request = {}) override;
  bool HasJacobians() const override { return true; }
  Status EvaluateResidualJacobians(const std::vector<Coefficients>& sets, std::vector<std::vector<double>>* residuals,
                                   std::vector<std::vector<double>>* jacobians,
                                   const EvaluationRequest& request = {}) override;
  // Fixed (not the number of connected workers) so that a job's calls are the same
  // in every run.
  int parallelism() const override { return parallelism_; }

 private:
  // The call's results, one per task of whole lane groups in order (the shares of a
  // call split by worm already combined).
  Status RunTasks(const std::vector<Coefficients>& sets, TaskKind kind, const EvaluationRequest& request,
                  const RunningCut* cut, std::vector<TaskResult>* results);
  // The task of sets [first, first + count) of a call; `id_suffix` tells apart tasks of
  // the same sets (a worm's share, a cut).
  TaskSpec NewTask(TaskKind kind, const std::vector<Coefficients>& sets, size_t first, size_t count,
                   const std::string& id_suffix) const;
  Status RunWormShares(const std::vector<Coefficients>& sets, TaskKind kind, const EvaluationRequest& request,
                       std::vector<TaskResult>* results);
  Scheduler& scheduler_;
  std::shared_ptr<const PairedPath> pair_;
  int64_t job_;
  bool screening_;
  int chunk_;
  int parallelism_;
};

}  // namespace wormdrag::server
