#include "core/jobs/bootstrap_run.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

namespace wormdrag {

Result<ScoredSet> FitReplicate(const PairedPath& pair, const ScoredSet& estimate, const std::array<double, 2>& noise_mm,
                               const JobOptions& options, int index, PhaseSummary* summary) {
  auto raw = MakeReplicate(pair, estimate.set, noise_mm, options.bootstrap.seed + static_cast<uint64_t>(index));
  if (!raw.ok()) return raw.status();
  std::array<Kinematics, 2> smoothed;
  const std::array<std::string, 2> names = {pair.worm(0).name + " (replicate " + std::to_string(index) + ")",
                                            pair.worm(1).name + " (replicate " + std::to_string(index) + ")"};
  for (int j = 0; j < 2; ++j) {
    auto k = SmoothRecording(names[j], (*raw)[j], options);
    if (!k.ok()) return k.status();
    smoothed[j] = std::move(*k);
  }
  auto replicate = PairedPath::Create(smoothed, names, pair.options());
  if (!replicate.ok()) return replicate.status();
  LocalEvaluator evaluator(*replicate, 1);
  PhaseSummary own;
  return RunPhase3({estimate}, options.estimate.search, options.estimate.phase3, evaluator, summary ? summary : &own);
}

Result<BootstrapReport> RunBootstrapLocal(const PairedPath& pair, const ScoredSet& estimate,
                                          const std::array<double, 2>& noise_mm, const JobOptions& options,
                                          int threads, const BootstrapHooks& hooks) {
  const BootstrapOptions& bo = options.bootstrap;
  WORMDRAG_RETURN_IF_ERROR(bo.Validate());
  std::array<double, 2> noise = noise_mm;
  for (int j = 0; j < 2; ++j)
    noise[j] = std::max(noise[j], bo.noise_floor_percent_bl / 100 * pair.worm(j).body_length());
  const int n = bo.replicates;
  std::vector<Coefficients> fits(n);
  std::vector<bool> ok(n, false);
  std::atomic<int> next{0}, done{0};
  std::atomic<bool> stop{false};
  std::mutex mu;
  Status failure = Status::Ok();
  auto work = [&]() {
    for (;;) {
      const int r = next.fetch_add(1);
      if (r >= n || stop.load()) return;
      auto fit = FitReplicate(pair, estimate, noise, options, r);
      std::lock_guard<std::mutex> lock(mu);
      if (fit.ok()) {
        fits[r] = fit->set;
        ok[r] = true;
      }
      const int d = ++done;
      if (hooks.progress) hooks.progress(d, n);
      if (hooks.cancelled && hooks.cancelled()) {
        stop = true;
        failure = Status::Cancelled("cancelled during the bootstrap");
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::min(std::max(1, threads), n); ++t) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
  WORMDRAG_RETURN_IF_ERROR(failure);
  BootstrapReport report = SummariseBootstrap(estimate.set, fits, ok, options.estimate.search.d_mu,
                                              options.estimate.search.d_eta, bo);
  report.noise_mm = noise;
  return report;
}

}  // namespace wormdrag
