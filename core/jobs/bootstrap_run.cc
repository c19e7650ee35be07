#include "core/jobs/bootstrap_run.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/common/parallel.h"

namespace wormdrag {

namespace {

// Replicate indices of the check and of the smoothing check: apart from the basic
// replicates' 0 … n−1.
constexpr int kCheckIndexBase = 10000;
constexpr int kSmoothingIndexBase = 20000;

double Combination(const Coefficients& c, int which) {
  return which == 0 ? c.K_mu() : which == 1 ? c.K_eta() : c.v_c();
}

// `c` with one combination moved to `value`, the others kept.
Coefficients WithCombination(Coefficients c, int which, double value) {
  if (which == 0) c.mu_n = value * c.mu_t;
  if (which == 1) c.eta_n = value * c.eta_t;
  if (which == 2) {
    const double f = value / c.v_c();
    c.mu_n *= f;
    c.mu_t *= f;
  }
  return c;
}

// The smoothing check: the data refitted at λ ÷ and × the factor. Each refit, moved by
// the bias correction the interval applies to the fit, widens a determined
// combination's interval to hold it and its mirror image about the corrected value:
// the interval then holds what the data say under any of those smoothings, and the
// max_ratio rule applies to it again. The mirror is there because the bias that
// smoothing leaves at GCV's λ has no refit of its own: where both refits move the same
// way (too little smoothing leaves noise, too much removes shape, and either can push a
// ratio up), the fit at GCV's λ carries some of that push too, of unknown size; the
// excess a decade away is the scale the data give for it.
Status SmoothingCheck(const ScoredSet& estimate, const JobOptions& options, const ReplicateRunner& runner,
                      const DataAtSmoothing& data_at_smoothing, const std::function<bool()>& cancelled,
                      CombinationInterval* const combos[3], BootstrapReport* report) {
  const double factor = options.bootstrap.smoothing_check;
  if (!data_at_smoothing || factor == 0 || !(combos[0]->determined || combos[1]->determined || combos[2]->determined))
    return Status::Ok();
  for (double scale : {1 / factor, factor}) {
    auto pair = data_at_smoothing(scale);
    if (!pair.ok()) return pair.status();
    const int index = kSmoothingIndexBase + static_cast<int>(report->smoothing_fits.size());
    ReplicateTask task{index, estimate, std::nullopt, {0, 0}, true, scale};
    auto fits = runner(
        **pair, {task}, options, [](int, int) {}, cancelled);
    if (!fits.ok()) return fits.status();
    const auto& fit = (*fits)[0];
    report->smoothing_fits.push_back({scale, fit ? std::optional<Coefficients>(fit->set) : std::nullopt});
  }
  for (int which = 0; which < 3; ++which) {
    CombinationInterval* g = combos[which];
    if (!g->determined) continue;
    const double shift = g->estimate > 0 ? g->corrected / g->estimate : 1;
    double moved[2];
    for (int k = 0; k < 2; ++k) {
      const auto& fit = report->smoothing_fits[k].second;
      moved[k] = fit ? Combination(*fit, which) * shift : NAN;
    }
    char buf[400];
    if (!(moved[0] > 0 && moved[1] > 0 && std::isfinite(moved[0]) && std::isfinite(moved[1]))) {
      std::snprintf(buf, sizeof buf, "a refit of the data smoothed %g times less or more failed or left it undefined",
                    factor);
      g->determined = false;
      g->why = buf;
      continue;
    }
    const double c = g->corrected;
    g->lo = std::min({g->lo, moved[0], moved[1], c * c / moved[0], c * c / moved[1]});
    g->hi = std::max({g->hi, moved[0], moved[1], c * c / moved[0], c * c / moved[1]});
    if (g->hi > options.bootstrap.max_ratio * g->lo) {
      std::snprintf(buf, sizeof buf,
                    "with the data smoothed %g times less and more (refits %.4g and %.4g, bias-corrected) its "
                    "interval spans a factor %.3g (more than %g): the value rests on detail of the shapes that "
                    "smoothing cannot tell from noise",
                    factor, moved[0], moved[1], g->hi / g->lo, options.bootstrap.max_ratio);
      g->determined = false;
      g->why = buf;
    }
  }
  return Status::Ok();
}

// Phase 3 from the estimate, within the relaxation-time bound as the job bounds the
// data's fit: a free refit may shrink the scale where the data's fit could not, and
// its ratios move with the scale.
Result<ScoredSet> RefitBounded(std::shared_ptr<const PairedPath> pair, const ReplicateTask& task,
                               const JobOptions& options, PhaseSummary* summary, int threads) {
  LocalEvaluator evaluator(pair, threads);
  const EstimateOptions& o = options.estimate;
  auto fit = RunPhase3({task.estimate}, o.search, o.phase3, evaluator, summary);
  if (!fit.ok()) return fit.status();
  auto bounded = BoundScaleOf(*fit, {task.estimate}, o.search, o.phase3, FactsOf(*pair), evaluator, &summary->sets);
  // A refit whose path cannot be simulated has no E to compare with the data's.
  if (bounded.ok() && !std::isfinite(bounded->e))
    return Status::FailedPrecondition("refit " + std::to_string(task.index) + ": its path cannot be simulated");
  return bounded;
}

// The check of decisions 0030 and 0048: replicates made with each determined combination
// moved by bo.check_factor either way are refitted. A combination is withheld when the
// moved replicates refit around the data's own fit, since the data do not tell them
// apart, and when they all refit beyond it, on the far side from where they were made:
// replicates made below the corrected value that all refit above the data's fit say,
// the estimator's response being monotone, that the truth lies lower still (the
// correction overshoots where the estimator's bias grows away from the truth), and
// likewise above. Every group's range is recorded (report->checks). Progress counts on
// from `done_before`, the refits of the bootstrap already run.
Status MadeAwayCheck(const PairedPath& pair, const ScoredSet& estimate, const std::array<double, 2>& noise,
                     const JobOptions& options, const ReplicateRunner& runner, int done_before,
                     const std::function<void(int, int)>& progress, const std::function<bool()>& cancelled,
                     CombinationInterval* const combos[3], BootstrapReport* report) {
  const BootstrapOptions& bo = options.bootstrap;
  struct Candidate {
    int which;
    double value;
  };
  std::vector<Candidate> candidates;
  std::vector<ReplicateTask> tasks;
  for (int which = 0; which < 3 && bo.check_replicates > 0; ++which) {
    if (!combos[which]->determined) continue;
    for (double f : {bo.check_factor, 1 / bo.check_factor}) {
      const double value = combos[which]->corrected * f;
      for (int r = 0; r < bo.check_replicates; ++r)
        tasks.push_back({kCheckIndexBase + 100 * static_cast<int>(candidates.size()) + r, estimate,
                         WithCombination(estimate.set, which, value), noise});
      candidates.push_back({which, value});
    }
  }
  if (tasks.empty()) return Status::Ok();
  const std::function<void(int, int)> check_progress = [&](int done, int total) {
    if (progress) progress(done_before + done, done_before + total);
  };
  auto checks = runner(pair, tasks, options, check_progress, cancelled);
  if (!checks.ok()) return checks.status();
  report->check_refits = static_cast<int>(tasks.size());
  for (size_t k = 0; k < candidates.size(); ++k) {
    const Candidate& c = candidates[k];
    CombinationInterval* g = combos[c.which];
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (int r = 0; r < bo.check_replicates; ++r) {
      const auto& fit = (*checks)[k * bo.check_replicates + r];
      if (!fit) continue;
      const double v = Combination(fit->set, c.which);
      lo = std::min(lo, std::isnan(v) ? 0.0 : v);
      hi = std::max(hi, std::isnan(v) ? HUGE_VAL : v);
    }
    report->checks.push_back({g->name, c.value, lo, hi});
    if (!g->determined || lo > hi) continue;
    const double data = g->estimate;
    const bool below = c.value < g->corrected;
    const char* where = nullptr;
    const char* meaning = nullptr;
    if (lo <= data && data <= hi) {
      where = "around", meaning = "the data do not tell them apart";
    } else if (below && lo > data) {
      where = "all above", meaning = "the truth lies lower still, and the bias correction overshoots";
    } else if (!below && hi < data) {
      where = "all below", meaning = "the truth lies higher still, and the bias correction falls short";
    }
    if (where) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "replicates made with %s = %.4g (%.3g times the corrected value) refit to %.4g … %.4g, %s this "
                    "fit (%.4g): %s",
                    g->name.c_str(), c.value, c.value / g->corrected, lo, hi, where, data, meaning);
      g->determined = false;
      g->why = buf;
    }
  }
  return Status::Ok();
}

}  // namespace

Result<ScoredSet> FitReplicate(const PairedPath& pair, const ReplicateTask& task, const JobOptions& options,
                               PhaseSummary* summary, int threads) {
  PhaseSummary own;
  if (!summary) summary = &own;
  // `pair` outlives the evaluator: a non-owning pointer is enough.
  if (task.refit_data)
    return RefitBounded(std::shared_ptr<const PairedPath>(&pair, [](const PairedPath*) {}), task, options, summary,
                        threads);
  const Coefficients model = task.model ? *task.model : task.estimate.set;
  auto raw = MakeReplicate(pair, model, task.noise_mm, options.bootstrap.seed + static_cast<uint64_t>(task.index));
  if (!raw.ok()) return raw.status();
  std::array<Kinematics, 2> smoothed;
  const std::string tag = " (replicate " + std::to_string(task.index) + ")";
  const std::array<std::string, 2> names = {pair.worm(0).name + tag, pair.worm(1).name + tag};
  for (int j = 0; j < 2; ++j) {
    auto k = SmoothRecording(names[j], (*raw)[j], options);
    if (!k.ok()) return k.status();
    smoothed[j] = std::move(*k);
  }
  auto replicate = PairedPath::Create(smoothed, names, pair.options());
  if (!replicate.ok()) return replicate.status();
  return RefitBounded(*replicate, task, options, summary, threads);
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
  nlohmann::json j = {{"index", t.index},
                      {"estimate", {c.mu_n, c.mu_t, c.eta_n, c.eta_t}},
                      {"E", t.estimate.e},
                      {"noise_mm", {t.noise_mm[0], t.noise_mm[1]}}};
  if (t.model) j["model"] = {t.model->mu_n, t.model->mu_t, t.model->eta_n, t.model->eta_t};
  if (t.refit_data) j["refit_data"] = true, j["smoothing_scale"] = t.smoothing_scale;
  return j.dump();
}

Result<ReplicateTask> ReplicateTaskFromJson(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object()) return Status::InvalidArgument("bootstrap task: not a JSON object");
  ReplicateTask t;
  try {
    t.index = j.at("index").get<int>();
    const auto c = j.at("estimate").get<std::vector<double>>();
    const auto n = j.at("noise_mm").get<std::vector<double>>();
    if (c.size() != 4 || n.size() != 2)
      return Status::InvalidArgument("bootstrap task: estimate needs 4 values, noise 2");
    t.estimate = {{c[0], c[1], c[2], c[3]}, j.at("E").get<double>()};
    t.noise_mm = {n[0], n[1]};
    if (j.contains("model")) {
      const auto m = j.at("model").get<std::vector<double>>();
      if (m.size() != 4) return Status::InvalidArgument("bootstrap task: model needs 4 values");
      t.model = Coefficients{m[0], m[1], m[2], m[3]};
    }
    t.refit_data = j.value("refit_data", false);
    t.smoothing_scale = j.value("smoothing_scale", 1.0);
  } catch (const nlohmann::json::exception& e) {
    return Status::InvalidArgument(std::string("bootstrap task: ") + e.what());
  }
  WORMDRAG_RETURN_IF_ERROR(CheckReplicateTask(t));
  return t;
}

Status CheckReplicateTask(const ReplicateTask& t) {
  if (!(t.smoothing_scale > 0 && t.smoothing_scale < 1e6))
    return Status::InvalidArgument("bootstrap task: smoothing_scale must lie in (0, 1e6)");
  const Coefficients& c = t.estimate.set;
  std::vector<double> all = {c.mu_n, c.mu_t, c.eta_n, c.eta_t, t.noise_mm[0], t.noise_mm[1]};
  if (t.model) all.insert(all.end(), {t.model->mu_n, t.model->mu_t, t.model->eta_n, t.model->eta_t});
  for (double v : all)
    if (!std::isfinite(v) || v < 0) return Status::InvalidArgument("bootstrap task: values must be finite and >= 0");
  if (t.index < 0 || t.index > 100000) return Status::InvalidArgument("bootstrap task: index out of range");
  return Status::Ok();
}

std::vector<double> RunReplicateTask(const PairedPath& pair, const ReplicateTask& t, const JobOptions& options,
                                     int threads) {
  auto fit = FitReplicate(pair, t, options, nullptr, threads);
  if (!fit.ok()) return {0, 0, 0, 0, 0, 0};
  return {1, fit->set.mu_n, fit->set.mu_t, fit->set.eta_n, fit->set.eta_t, fit->e};
}

ReplicateRunner LocalReplicateRunner(int threads) {
  return [threads](const PairedPath& pair, const std::vector<ReplicateTask>& tasks, const JobOptions& options,
                   const std::function<void(int, int)>& progress,
                   const std::function<bool()>& cancelled) -> Result<std::vector<std::optional<ScoredSet>>> {
    const int n = static_cast<int>(tasks.size());
    std::vector<std::optional<ScoredSet>> fits(n);
    std::atomic<int> done{0};
    std::atomic<bool> stop{false};
    std::mutex mu;
    ParallelFor(n, threads, [&](int, int64_t r) {
      if (stop.load()) return;
      // Each refit may use every thread: while the refits keep the pool busy its
      // evaluations run on their own thread, and the last ones take the threads the
      // others leave (the answer does not depend on them).
      auto fit = FitReplicate(pair, tasks[r], options, nullptr, threads);
      std::lock_guard<std::mutex> lock(mu);
      if (fit.ok()) fits[r] = *fit;
      const int d = ++done;
      if (progress) progress(d, n);
      if (cancelled && cancelled()) stop = true;
    });
    if (stop.load()) return Status::Cancelled("cancelled during the bootstrap");
    return fits;
  };
}

Result<BootstrapReport> RunBootstrap(const PairedPath& pair, const ScoredSet& estimate,
                                     const std::array<double, 2>& noise_mm, const JobOptions& options,
                                     const ReplicateRunner& runner, const DataAtSmoothing& data_at_smoothing,
                                     const std::function<void(int, int)>& progress,
                                     const std::function<bool()>& cancelled) {
  const BootstrapOptions& bo = options.bootstrap;
  WORMDRAG_RETURN_IF_ERROR(bo.Validate());
  double share = 0;
  const std::array<double, 2> noise = ReplicateNoise(pair, noise_mm, bo, &share);
  std::vector<ReplicateTask> tasks;
  for (int r = 0; r < bo.replicates; ++r) tasks.push_back({r, estimate, std::nullopt, noise});
  auto fits = runner(pair, tasks, options, progress, cancelled);
  if (!fits.ok()) return fits.status();
  std::vector<Coefficients> sets(fits->size());
  std::vector<bool> ok(fits->size(), false);
  std::vector<double> fit_e;
  for (size_t r = 0; r < fits->size(); ++r)
    if ((*fits)[r]) sets[r] = (*fits)[r]->set, ok[r] = true, fit_e.push_back((*fits)[r]->e);
  BootstrapReport report = SummariseBootstrap(estimate.set, sets, ok, options.estimate.search.d_mu,
                                              options.estimate.search.d_eta, bo, share, FactsOf(pair).link_speed);
  report.noise_mm = noise;
  CheckMisfit(estimate.e, fit_e, &report);
  CombinationInterval* combos[3] = {&report.K_mu, &report.K_eta, &report.v_c};
  WORMDRAG_RETURN_IF_ERROR(SmoothingCheck(estimate, options, runner, data_at_smoothing, cancelled, combos, &report));
  WORMDRAG_RETURN_IF_ERROR(MadeAwayCheck(pair, estimate, noise, options, runner,
                                         static_cast<int>(fits->size() + report.smoothing_fits.size()), progress,
                                         cancelled, combos, &report));
  RequireCrossover(estimate.set, bo, &report);
  return report;
}

}  // namespace wormdrag
