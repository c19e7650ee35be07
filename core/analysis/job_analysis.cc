#include "core/analysis/job_analysis.h"

#include <cmath>
#include <limits>
#include <optional>

#include <nlohmann/json.hpp>

namespace wormdrag {

const char* CoefficientName(int index) {
  static const char* kNames[] = {"mu_n", "mu_t", "eta_n", "eta_t"};
  return kNames[index];
}
const char* CoefficientSymbol(int index) {
  static const char* kSymbols[] = {"μn", "μt", "ηn", "ηt"};
  return kSymbols[index];
}

Result<LoadedJob> LoadDoneJob(JobStore& store, int64_t id) {
  auto job = store.GetJob(id);
  if (!job.ok()) return job.status();
  const std::string name = "job " + std::to_string(id);
  if (job->kind != "estimate")
    return Status::FailedPrecondition(name + " is a '" + job->kind + "' job, not an estimation");
  if (job->state != JobState::kDone)
    return Status::FailedPrecondition(name + " is " + JobStateName(job->state) +
                                      (job->error.empty() ? "" : " (" + job->error + ")") +
                                      "; only a finished (done) job can be analysed");
  LoadedJob out;
  out.job = *job;
  auto opt = JobOptionsFromJson(job->options_json, OptionsUse::kAnalyse);
  if (!opt.ok()) return Status::FailedPrecondition(name + ": stored options unreadable: " + opt.status().message());
  out.options = *opt;
  auto j = nlohmann::json::parse(job->result_json, nullptr, false);
  if (j.is_discarded() || !j.contains("estimate"))
    return Status::FailedPrecondition(name + ": stored result unreadable");
  const auto& e = j["estimate"];
  try {
    out.estimate = {e.at("mu_n").get<double>(), e.at("mu_t").get<double>(), e.at("eta_n").get<double>(),
                    e.at("eta_t").get<double>()};
    out.e_mm = e.at("E_mm").get<double>();
    out.e_percent = j.value("E_percent_BL", 0.0);
  } catch (const std::exception& ex) {
    return Status::FailedPrecondition(name + ": stored result incomplete: " + ex.what());
  }
  auto pair = LoadPair(store, *job, out.options, out.options.estimate.eval);
  if (!pair.ok()) return pair.status();
  out.pair = *pair;
  return out;
}

Result<CoefficientTrajectories> CompareCoefficientSets(const PairedPath& pair, const std::vector<Coefficients>& sets) {
  if (sets.empty()) return Status::InvalidArgument("no coefficient set to simulate");
  CoefficientTrajectories out;
  out.body_length = pair.mean_body_length();
  for (const auto& c : sets) {
    auto cmp = ComparePaths(pair, c);
    if (!cmp.ok()) return cmp.status();
    std::array<double, 2> ew{};
    for (int j = 0; j < 2; ++j) {
      double s = 0;
      long n = 0;
      for (size_t f = 0; f < cmp->measured[j].size(); ++f)
        for (size_t i = 0; i < cmp->measured[j][f].size(); ++i, ++n)
          s += (cmp->measured[j][f][i] - cmp->simulated[j][f][i]).norm();
      ew[j] = n ? s / n : 0;
    }
    double d = 0;
    long n = 0;
    if (!out.paths.empty()) {
      const auto& first = out.paths.front();
      for (int j = 0; j < 2; ++j)
        for (size_t f = 0; f < cmp->simulated[j].size(); ++f)
          for (size_t i = 0; i < cmp->simulated[j][f].size(); ++i, ++n)
            d += (cmp->simulated[j][f][i] - first.simulated[j][f][i]).norm();
    }
    out.sets.push_back(c);
    out.e_mm.push_back(cmp->e_mm);
    out.e_mm_worm.push_back(ew);
    out.distance_to_first_mm.push_back(n ? d / n : 0);
    out.paths.push_back(std::move(*cmp));
  }
  return out;
}

Result<GridSlices> PhaseOneSlices(JobStore& store, const JobRecord& job, const SearchOptions& search) {
  WORMDRAG_RETURN_IF_ERROR(search.Validate());
  const std::vector<Coefficients> grid = GridSets(search);
  std::vector<std::optional<double>> e;
  WORMDRAG_RETURN_IF_ERROR(store.LookupEvaluations(job.eval_key, grid, &e));
  GridSlices out;
  out.search = search;
  out.total = static_cast<int64_t>(grid.size());
  int best = -1;
  for (size_t i = 0; i < grid.size(); ++i) {
    if (!e[i] || !std::isfinite(*e[i])) continue;
    ++out.evaluated;
    if (best < 0 || *e[i] < *e[best]) best = static_cast<int>(i);
  }
  if (best < 0) return Status::FailedPrecondition("job " + std::to_string(job.id) + ": no Phase 1 value in the store");
  out.optimum = grid[best];
  out.e_opt = *e[best];
  const int n = search.n_max + 1;
  const double step[4] = {search.d_mu, search.d_mu, search.d_eta, search.d_eta};
  std::array<int, 4> opt_index;
  const auto oa = out.optimum.AsArray();
  for (int c = 0; c < 4; ++c) opt_index[c] = static_cast<int>(std::lround(oa[c] / step[c]));
  // Index of a grid point in GridSets' order, found by value (robust to its loop order).
  auto key = [&](const std::array<int, 4>& idx) { return ((idx[0] * n + idx[1]) * n + idx[2]) * n + idx[3]; };
  std::vector<int> where(grid.size(), -1);
  for (size_t i = 0; i < grid.size(); ++i) {
    const auto a = grid[i].AsArray();
    std::array<int, 4> idx;
    bool on_grid = true;
    for (int c = 0; c < 4; ++c) {
      idx[c] = static_cast<int>(std::lround(a[c] / step[c]));
      if (idx[c] < 0 || idx[c] >= n) on_grid = false;
    }
    if (on_grid) where[key(idx)] = static_cast<int>(i);
  }
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      GridSlice s;
      s.a = a;
      s.b = b;
      for (int i = 0; i < n; ++i) {
        s.va.push_back(i * step[a]);
        s.vb.push_back(i * step[b]);
      }
      s.e.assign(static_cast<size_t>(n) * n, std::numeric_limits<double>::quiet_NaN());
      for (int ia = 0; ia < n; ++ia)
        for (int ib = 0; ib < n; ++ib) {
          auto idx = opt_index;
          idx[a] = ia;
          idx[b] = ib;
          const int g = where[key(idx)];
          if (g >= 0 && e[g] && std::isfinite(*e[g])) s.e[static_cast<size_t>(ia) * n + ib] = *e[g];
        }
      out.slices.push_back(std::move(s));
    }
  return out;
}

}  // namespace wormdrag
