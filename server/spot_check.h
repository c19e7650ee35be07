// Spot-checks of workers' results (docs/reliability.md, "Workers that lie").
//
// Shape and range checks cannot catch a worker that returns plausible but wrong
// numbers (a bug, a broken machine, a hostile process with a worker token). So a
// small, deterministic fraction of the tasks is run twice: the first result is held
// back, the task is leased again to a *different* worker, and the two results are
// compared. When they agree the result is accepted; when they differ a third worker
// decides, the worker whose result disagrees with the other two is quarantined, and
// only the agreeing result is stored. The Scheduler drives this (scheduler_spot.cc);
// the pure parts are here.
#pragma once

#include <cstdint>
#include <string>

#include "server/scheduler.h"

namespace wormdrag::server {

// Whether `task_id` is spot-checked at `fraction` (0 none, 1 every task). A hash of
// the id, which is content-addressed (MakeTaskId): a restarted coordinator checks the
// same tasks, and a worker cannot tell from a task whether it is being checked.
bool IsSpotChecked(const std::string& task_id, double fraction);

// The kinds whose results are compared: E values and residual vectors (with their
// Jacobians), each a deterministic function of the task. Diagnosis fits and
// bootstrap refits are optimiser runs whose path depends on the worker's thread count
// and are not checked.
bool IsSpotCheckable(TaskKind kind);

// Whether two results of `task` agree: the same shape, and every number within
// `relative_tolerance` of the other (relative to the larger magnitude). Infinities
// (sets that cannot be simulated) and NaN residuals must match exactly. An E one
// worker abandoned (NaN; the task's cut, or its set's group cut) agrees with the
// other's value only when that value lies above the cut the first worker can have
// reached: which sets are abandoned depends on the order in which a worker's threads
// tighten the cut, but a set abandoned below it is a wrong result.
bool ResultsAgree(const TaskResult& a, const TaskResult& b, double relative_tolerance, const TaskSpec& task);

}  // namespace wormdrag::server
