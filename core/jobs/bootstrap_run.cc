#include "core/jobs/bootstrap_run.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

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

std::array<double, 2> ReplicateNoise(const PairedPath& pair, const std::array<double, 2>& noise_mm,
                                     const BootstrapOptions& o, double* bias_share) {
  std::array<double, 2> noise = noise_mm;
  *bias_share = 0;
  for (int j = 0; j < 2; ++j) {
    noise[j] = std::max(noise[j], o.noise_floor_percent_bl / 100 * pair.worm(j).body_length());
    *bias_share += 0.5 * (noise[j] > 0 ? std::min(1.0, std::pow(noise_mm[j] / noise[j], 2)) : 1.0);
  }
  return noise;
}

std::string ReplicateTaskToJson(const ReplicateTask& t) {
  const Coefficients& c = t.estimate.set;
  return nlohmann::json{{"index", t.index},
                        {"estimate", {c.mu_n, c.mu_t, c.eta_n, c.eta_t}},
                        {"E", t.estimate.e},
                        {"noise_mm", {t.noise_mm[0], t.noise_mm[1]}}}
      .dump();
}

Result<ReplicateTask> ReplicateTaskFromJson(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object()) return Status::InvalidArgument("bootstrap task: not a JSON object");
  ReplicateTask t;
  try {
    t.index = j.at("index").get<int>();
    const auto c = j.at("estimate").get<std::vector<double>>();
    const auto n = j.at("noise_mm").get<std::vector<double>>();
    if (c.size() != 4 || n.size() != 2) return Status::InvalidArgument("bootstrap task: estimate needs 4 values, noise 2");
    t.estimate = {{c[0], c[1], c[2], c[3]}, j.at("E").get<double>()};
    t.noise_mm = {n[0], n[1]};
  } catch (const nlohmann::json::exception& e) {
    return Status::InvalidArgument(std::string("bootstrap task: ") + e.what());
  }
  for (double v : {t.estimate.set.mu_n, t.estimate.set.mu_t, t.estimate.set.eta_n, t.estimate.set.eta_t,
                   t.noise_mm[0], t.noise_mm[1]})
    if (!std::isfinite(v) || v < 0) return Status::InvalidArgument("bootstrap task: values must be finite and >= 0");
  if (t.index < 0 || t.index > 100000) return Status::InvalidArgument("bootstrap task: index out of range");
  return t;
}

std::vector<double> RunReplicateTask(const PairedPath& pair, const ReplicateTask& t, const JobOptions& options) {
  auto fit = FitReplicate(pair, t.estimate, t.noise_mm, options, t.index);
  if (!fit.ok()) return {0, 0, 0, 0, 0};
  return {1, fit->set.mu_n, fit->set.mu_t, fit->set.eta_n, fit->set.eta_t};
}

Result<BootstrapReport> RunBootstrapLocal(const PairedPath& pair, const ScoredSet& estimate,
                                          const std::array<double, 2>& noise_mm, const JobOptions& options,
                                          int threads, const BootstrapHooks& hooks) {
  const BootstrapOptions& bo = options.bootstrap;
  WORMDRAG_RETURN_IF_ERROR(bo.Validate());
  double share = 0;
  const std::array<double, 2> noise = ReplicateNoise(pair, noise_mm, bo, &share);
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
                                              options.estimate.search.d_eta, bo, share,
                                              FactsOf(pair).link_speed);
  report.noise_mm = noise;
  return report;
}

}  // namespace wormdrag
