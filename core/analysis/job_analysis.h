// The paper's §4 analyses and the report's figures for a stored job: the job's
// recordings and estimate, trajectories for several coefficient sets (Fig. 11, 13),
// and E over the Phase 1 grid as 2-D slices through the optimum.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/estimate/paired_path.h"
#include "core/estimate/search.h"
#include "core/jobs/estimate_job.h"
#include "core/store/job_store.h"

namespace wormdrag {

// A finished estimation job with its recordings prepared exactly as the job saw them
// (filter, t_max, gap restarts, evaluation points).
struct LoadedJob {
  JobRecord job;
  JobOptions options;
  std::shared_ptr<const PairedPath> pair;
  Coefficients estimate;
  double e_mm = 0, e_percent = 0;
};

// NOT_FOUND for an unknown id; FAILED_PRECONDITION for a job that is not a finished
// estimation (queued, running, failed, cancelled, or another kind).
Result<LoadedJob> LoadDoneJob(JobStore& store, int64_t id);

// Fig. 11 / 13: the same joint angles driven with several coefficient sets.
struct CoefficientTrajectories {
  std::vector<Coefficients> sets;
  std::vector<PathComparison> paths;             // per set (measured points are the same in each)
  std::vector<std::array<double, 2>> e_mm_worm;  // per set: E of each worm alone, mm
  std::vector<double> e_mm;                      // per set: E of the pair, mm
  std::vector<double> distance_to_first_mm;      // mean distance between set i's and set 0's simulated points
  double body_length = 0;                        // mean of the pair, mm
};
Result<CoefficientTrajectories> CompareCoefficientSets(const PairedPath& pair, const std::vector<Coefficients>& sets);

// E over the Phase 1 grid through its best point: for every pair of coefficients
// (6 slices), E on the grid with the other two held at the optimum's values. Values
// come from the store under the job's eval key (so also when they were reused from
// an earlier job); a grid point never evaluated is NaN.
struct GridSlice {
  int a = 0, b = 0;            // coefficient indices (0 μ_n, 1 μ_t, 2 η_n, 3 η_t)
  std::vector<double> va, vb;  // grid values along a and b
  std::vector<double> e;       // e[ia * vb.size() + ib], mm; NaN = not evaluated / failed
};
struct GridSlices {
  SearchOptions search;
  Coefficients optimum;
  double e_opt = 0;
  int64_t evaluated = 0, total = 0;  // grid points with a stored finite E, of all
  std::vector<GridSlice> slices;
};
Result<GridSlices> PhaseOneSlices(JobStore& store, const JobRecord& job, const SearchOptions& search);

const char* CoefficientName(int index);    // "mu_n", "mu_t", "eta_n", "eta_t"
const char* CoefficientSymbol(int index);  // "μn", … (for figures)

}  // namespace wormdrag
