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

// The chunks of kLanes sets that n sets fill.
int64_t Chunks(int64_t n) {
  return (n + kLanes - 1) / kLanes;
}

// Runs chunk(tid, first, count) over [0, n) in chunks of kLanes on `threads` threads.
void ParallelChunks(int threads, int64_t n, const std::function<void(int, int64_t, int)>& chunk,
                    const ProgressFn& progress) {
  std::atomic<int64_t> done{0};
  std::mutex progress_mu;
  ParallelFor(Chunks(n), threads, [&](int tid, int64_t c) {
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
  return threads > 1 && Chunks(n) < threads;
}

// A SplitByWorm batch: worm(tid, chunk, j, first, count) for both worms j of every chunk
// of kLanes sets, each (chunk, worm) pair a task of its own, then done(chunk, first,
// count) once per chunk, in order, on the calling thread.
void ChunkWormsApart(int threads, int64_t n, const std::function<void(int, int64_t, int, int64_t, int)>& worm,
                     const std::function<void(int64_t, int64_t, int)>& done) {
  auto count_of = [n](int64_t first) { return static_cast<int>(std::min<int64_t>(kLanes, n - first)); };
  ParallelFor(2 * Chunks(n), threads, [&](int tid, int64_t k) {
    const int64_t first = k / 2 * kLanes;
    worm(tid, k / 2, static_cast<int>(k % 2), first, count_of(first));
  });
  for (int64_t c = 0; c < Chunks(n); ++c) done(c, c * kLanes, count_of(c * kLanes));
}

using CombineFn = std::function<void(int64_t first, int count, const std::array<WormLanes, 2>& worms)>;

// A batch worm by worm, in chunks of kLanes sets: each chunk's two worms on one thread,
// or on two when the batch is small (SplitByWorm); combine(first, count, worms) runs once
// per chunk with both worms done (chunks write disjoint outputs).
void RunWormLanes(const PairedPath& pair, const std::vector<Coefficients>& sets, LaneOutput what, int threads,
                  std::vector<EvaluationWorkspace>& workspaces, const ProgressFn& progress, const CombineFn& combine) {
  const int64_t n = static_cast<int64_t>(sets.size());
  if (!SplitByWorm(threads, n)) {
    ParallelChunks(
        threads, n,
        [&](int tid, int64_t first, int count) {
          std::array<WormLanes, 2> worms;
          for (int j = 0; j < 2; ++j) SimulateWormLanes(pair, j, &sets[first], count, what, workspaces[tid], &worms[j]);
          combine(first, count, worms);
        },
        progress);
    return;
  }
  std::vector<std::array<WormLanes, 2>> worms(Chunks(n));
  ChunkWormsApart(
      threads, n,
      [&](int tid, int64_t c, int j, int64_t first, int count) {
        SimulateWormLanes(pair, j, &sets[first], count, what, workspaces[tid], &worms[c][j]);
      },
      [&](int64_t c, int64_t first, int count) { combine(first, count, worms[c]); });
  if (progress) progress(n, n);
}

}  // namespace

LocalEvaluator::LocalEvaluator(std::shared_ptr<const PairedPath> pair, int threads)
    : pair_(std::move(pair)), threads_(std::max(1, threads)), workspaces_(threads_) {}

void LocalEvaluator::EvaluateWorm(const std::vector<Coefficients>& sets, int worm, LaneOutput what,
                                  std::vector<WormLanes>* chunks) {
  const int64_t n = static_cast<int64_t>(sets.size());
  chunks->assign(Chunks(n), WormLanes());
  ParallelChunks(
      threads_, n,
      [&](int tid, int64_t first, int count) {
        SimulateWormLanes(*pair_, worm, &sets[first], count, what, workspaces_[tid], &(*chunks)[first / kLanes]);
      },
      nullptr);
}

Status LocalEvaluator::Evaluate(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                const EvaluationRequest& request) {
  e->assign(sets.size(), kInf);
  auto count_knots = [&](int64_t knots, int count) {
    if (!request.knots) return;
    request.knots->simulated += knots;
    request.knots->full += count * pair_->knots_per_set();
  };
  if (!request.set_cuts.empty()) {
    WORMDRAG_RETURN_IF_ERROR(CheckSetCuts(sets, request));
    EvaluateAgainstSetCuts(sets, e, request, count_knots);
    return Status::Ok();
  }
  RunningCut* cut = request.objective == Objective::kMeanDistance ? request.cut : nullptr;
  if (!cut) {
    RunWormLanes(*pair_, sets, LaneOutput::kSums, threads_, workspaces_, request.progress,
                 [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                   CombineWormSums(*pair_, worms, count, request.objective, &(*e)[first]);
                   count_knots(worms[0].knots + worms[1].knots, count);
                 });
    return Status::Ok();
  }
  // Early abandoning simulates worm 2 only for the sets worm 1 left below the cut.
  ParallelChunks(
      threads_, static_cast<int64_t>(sets.size()),
      [&](int tid, int64_t first, int count) {
        double* out = &(*e)[first];
        count_knots(EvaluateLanes(*pair_, &sets[first], count, request.objective, workspaces_[tid], out, cut), count);
        for (int i = 0; i < count; ++i) cut->Offer(out[i]);
      },
      request.progress);
  return Status::Ok();
}

void LocalEvaluator::EvaluateAgainstSetCuts(const std::vector<Coefficients>& sets, std::vector<double>* e,
                                            const EvaluationRequest& request,
                                            const std::function<void(int64_t, int)>& count_knots) {
  const int64_t n = static_cast<int64_t>(sets.size());
  auto offer = [&](int64_t first, int count) {
    for (int i = 0; i < count; ++i) request.set_cuts[first + i]->Offer((*e)[first + i]);
  };
  if (!SplitByWorm(threads_, n)) {
    // A chunk's two worms on one thread: worm 1 runs only for the sets worm 0 left open.
    ParallelChunks(
        threads_, n,
        [&](int tid, int64_t first, int count) {
          count_knots(EvaluateLanes(*pair_, &sets[first], count, request.objective, workspaces_[tid], &(*e)[first],
                                    &request.set_cuts[first]),
                      count);
          offer(first, count);
        },
        request.progress);
    return;
  }
  // Too few chunks for the threads: each chunk's worms on two threads, each set
  // stopped on its sum against one worm.
  std::vector<std::array<std::array<double, kLanes>, 2>> sums(Chunks(n));
  std::vector<std::array<int64_t, 2>> knots(Chunks(n));
  ChunkWormsApart(
      threads_, n,
      [&](int tid, int64_t c, int j, int64_t first, int count) {
        knots[c][j] = SimulateWormAgainstCuts(*pair_, j, &sets[first], count, request.objective, workspaces_[tid],
                                              &request.set_cuts[first], sums[c][j].data());
      },
      [&](int64_t c, int64_t first, int count) {
        CombineWormsAgainstCuts(*pair_, sums[c][0].data(), sums[c][1].data(), count, &(*e)[first]);
        count_knots(knots[c][0] + knots[c][1], count);
        offer(first, count);
      });
  if (request.progress) request.progress(n, n);
}

Status LocalEvaluator::EvaluateResiduals(const std::vector<Coefficients>& sets,
                                         std::vector<std::vector<double>>* residuals,
                                         const EvaluationRequest& request) {
  residuals->assign(sets.size(), {});
  RunWormLanes(*pair_, sets, LaneOutput::kResiduals, threads_, workspaces_, request.progress,
               [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                 CombineWormResiduals(worms, count, &(*residuals)[first], nullptr);
               });
  return Status::Ok();
}

Status LocalEvaluator::EvaluateResidualJacobians(const std::vector<Coefficients>& sets,
                                                 std::vector<std::vector<double>>* residuals,
                                                 std::vector<std::vector<double>>* jacobians,
                                                 const EvaluationRequest& request) {
  residuals->assign(sets.size(), {});
  jacobians->assign(sets.size(), {});
  RunWormLanes(*pair_, sets, LaneOutput::kJacobians, threads_, workspaces_, request.progress,
               [&](int64_t first, int count, const std::array<WormLanes, 2>& worms) {
                 CombineWormResiduals(worms, count, &(*residuals)[first], &(*jacobians)[first]);
               });
  return Status::Ok();
}

}  // namespace wormdrag
