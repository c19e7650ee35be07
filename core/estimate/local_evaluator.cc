// The in-process evaluator: batches of sets in chunks of kLanes on local threads, and a
// small batch's two worms on two threads.
#include <algorithm>
#include <atomic>
#include <limits>
#include <mutex>

#include "core/common/parallel.h"
#include "core/estimate/paired_path.h"

namespace wormdrag {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Runs chunk(tid, first, count) over [0, n) in chunks of kLanes on `threads` threads.
void ParallelChunks(int threads, int64_t n, const std::function<void(int, int64_t, int)>& chunk,
                    const ProgressFn& progress) {
  std::atomic<int64_t> done{0};
  std::mutex progress_mu;
  ParallelFor((n + kLanes - 1) / kLanes, threads, [&](int tid, int64_t c) {
    const int64_t first = c * kLanes;
    const int count = static_cast<int>(std::min<int64_t>(kLanes, n - first));
    chunk(tid, first, count);
    const int64_t d = done.fetch_add(count) + count;
    if (progress) {
      std::lock_guard<std::mutex> lock(progress_mu);
      progress(d, n);
    }
  });
}

// Whether a batch of n sets leaves threads idle with one chunk of kLanes sets per
// thread: then each chunk's two worms run on two threads (SimulateWormLanes). Phase 3's
// Gauss–Newton steps and line searches evaluate one to a few sets at a time.
bool SplitByWorm(int threads, int64_t n) {
  return threads > 1 && (n + kLanes - 1) / kLanes < threads;
}

// The worms of every chunk of a batch, each (chunk, worm) on a thread of its own;
// combine(first, count, worms) then runs on the calling thread, chunk by chunk.
void ParallelWorms(const PairedPath& pair, const std::vector<Coefficients>& sets, LaneOutput what, int threads,
                   std::vector<EvaluationWorkspace>& workspaces, const ProgressFn& progress,
                   const std::function<void(int64_t, int, const std::array<WormLanes, 2>&)>& combine) {
  const int64_t n = static_cast<int64_t>(sets.size()), chunks = (n + kLanes - 1) / kLanes;
  std::vector<std::array<WormLanes, 2>> worms(chunks);
  ParallelFor(2 * chunks, threads, [&](int tid, int64_t k) {
    const int64_t first = k / 2 * kLanes;
    const int count = static_cast<int>(std::min<int64_t>(kLanes, n - first)), j = static_cast<int>(k % 2);
    SimulateWormLanes(pair, j, &sets[first], count, what, workspaces[tid], &worms[k / 2][j]);
  });
  for (int64_t c = 0; c < chunks; ++c) {
    const int64_t first = c * kLanes;
    combine(first, static_cast<int>(std::min<int64_t>(kLanes, n - first)), worms[c]);
  }
  if (progress) progress(n, n);
}

}  // namespace

LocalEvaluator::LocalEvaluator(std::shared_ptr<const PairedPath> pair, int threads)
    : pair_(std::move(pair)), threads_(std::max(1, threads)), workspaces_(threads_) {}

Status LocalEvaluator::Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                const EvaluationRequest& request) {
  e->assign(sets.size(), kInf);
  RunningCut* cut = request.objective == Objective::kMeanDistance ? request.cut : nullptr;
  auto count_knots = [&](int64_t knots, int count) {
    if (!request.knots) return;
    request.knots->simulated += knots;
    request.knots->full += count * pair_->knots_per_set();
  };
  if (!cut && SplitByWorm(threads_, static_cast<int64_t>(sets.size()))) {
    ParallelWorms(*pair_, sets, LaneOutput::kSums, threads_, workspaces_, request.progress,
                  [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                    CombineWormSums(*pair_, worms, count, request.objective, &(*e)[first]);
                    count_knots(worms[0].knots + worms[1].knots, count);
                  });
    return Status::Ok();
  }
  ParallelChunks(
      threads_, static_cast<int64_t>(sets.size()),
      [&](int tid, int64_t first, int count) {
        double* out = &(*e)[first];
        count_knots(EvaluateLanes(*pair_, &sets[first], count, request.objective, workspaces_[tid], out, cut), count);
        if (cut)
          for (int i = 0; i < count; ++i) cut->Offer(out[i]);
      },
      request.progress);
  return Status::Ok();
}

Status LocalEvaluator::EvaluateResiduals(const std::vector<Coefficients>& sets,
                                         std::vector<std::vector<double>>* residuals,
                                         const EvaluationRequest& request) {
  residuals->assign(sets.size(), {});
  if (SplitByWorm(threads_, static_cast<int64_t>(sets.size()))) {
    ParallelWorms(*pair_, sets, LaneOutput::kResiduals, threads_, workspaces_, request.progress,
                  [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                    CombineWormResiduals(worms, count, &(*residuals)[first], nullptr);
                  });
    return Status::Ok();
  }
  ParallelChunks(
      threads_, static_cast<int64_t>(sets.size()),
      [&](int tid, int64_t first, int count) {
        ResidualLanes(*pair_, &sets[first], count, workspaces_[tid], &(*residuals)[first]);
      },
      request.progress);
  return Status::Ok();
}

Status LocalEvaluator::EvaluateResidualJacobians(const std::vector<Coefficients>& sets,
                                                 std::vector<std::vector<double>>* residuals,
                                                 std::vector<std::vector<double>>* jacobians,
                                                 const EvaluationRequest& request) {
  residuals->assign(sets.size(), {});
  jacobians->assign(sets.size(), {});
  if (SplitByWorm(threads_, static_cast<int64_t>(sets.size()))) {
    ParallelWorms(*pair_, sets, LaneOutput::kJacobians, threads_, workspaces_, request.progress,
                  [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                    CombineWormResiduals(worms, count, &(*residuals)[first], &(*jacobians)[first]);
                  });
    return Status::Ok();
  }
  ParallelChunks(
      threads_, static_cast<int64_t>(sets.size()),
      [&](int tid, int64_t first, int count) {
        ResidualJacobianLanes(*pair_, &sets[first], count, workspaces_[tid], &(*residuals)[first],
                              &(*jacobians)[first]);
      },
      request.progress);
  return Status::Ok();
}

}  // namespace wormdrag
