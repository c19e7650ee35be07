// What a worker computes for a leased task: the coefficient sets of an estimation
// (E, residuals, Jacobians), a bootstrap replicate's refit or a diagnosis fit, on data
// fetched once per content hash, smoothed once per (datasets, options) and paired once
// per evaluation.
#pragma once

#include <array>
#include <functional>
#include <list>
#include <memory>
#include <string>
#include <utility>

#include "core/common/status.h"
#include "core/diagnose/fit_task.h"
#include "core/estimate/paired_path.h"
#include "core/jobs/estimate_job.h"
#include "wormdrag/v2/worker.pb.h"

namespace wormdrag::worker {

// The most recently used few of something expensive to build (paired paths, fit data).
template <typename T>
class RecentCache {
 public:
  // The entry for `key`, now the most recent; nullptr if absent.
  T* Find(const std::string& key) {
    for (auto it = items_.begin(); it != items_.end(); ++it)
      if (it->first == key) {
        items_.splice(items_.begin(), items_, it);
        return &items_.front().second;
      }
    return nullptr;
  }
  T* Put(const std::string& key, T value) {
    items_.emplace_front(key, std::move(value));
    while (items_.size() > kCapacity) items_.pop_back();
    return &items_.front().second;
  }

 private:
  static constexpr size_t kCapacity = 8;
  std::list<std::pair<std::string, T>> items_;  // most recently used first
};

class TaskRunner {
 public:
  // A dataset's content by its SHA-256 `hash` (`name` for messages).
  using FetchDataset = std::function<Result<std::string>(const std::string& hash, const std::string& name)>;
  TaskRunner(FetchDataset fetch, int threads) : fetch_(std::move(fetch)), threads_(threads) {}

  // Fills `rep`'s values or residuals, or its error: a task's inputs that fail, or make
  // the code throw, become the task's error report, never this process's end.
  void Run(const v2::Task& t, v2::ReportResultRequest* rep);

 private:
  struct Pair {
    std::shared_ptr<const PairedPath> pair;
    std::unique_ptr<LocalEvaluator> evaluator;
  };
  Status RunTask(const v2::Task& t, v2::ReportResultRequest* rep);
  Status RunSets(const v2::Task& t, Pair* pair, v2::ReportResultRequest* rep);
  Status RunWormShare(const v2::Task& t, const std::vector<Coefficients>& sets, LocalEvaluator& ev,
                      v2::ReportResultRequest* rep);
  Result<Pair*> GetPair(const v2::Task& t, double lambda_scale = 1);
  Status RunFit(const v2::Task& t, v2::ReportResultRequest* rep);

  FetchDataset fetch_;
  int threads_;
  RecentCache<std::array<Kinematics, 2>> recordings_;  // smoothed, by datasets and options
  RecentCache<Pair> pairs_;
  RecentCache<diagnose::EffectData> fit_data_;
};

}  // namespace wormdrag::worker
