// The paper's three-phase search for (μ_n, μ_t, η_n, η_t) (DESIGN §3, defaults from
// the paper's Table 1): a full grid, a local refinement around the best d1 %, and a
// GRG local optimisation from the best d2 % of the refinement.
#pragma once

#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/estimate/grg.h"
#include "core/estimate/paired_path.h"
#include "core/model/friction_law.h"

namespace wormdrag {

struct SearchOptions {
  int n_max = 10;         // Phase 1 grid N_i = 0 … n_max: (n_max+1)^4 sets
  double d_mu = 0.1;      // Δμ, µN
  double d_eta = 1e-3;    // Δη, µN·s/mm
  double d1 = 1.0;        // % of the grid kept for Phase 2
  double d2 = 0.2;        // % of the refinement kept for Phase 3
  int64_t max_sets = 2'000'000;  // refuse grids larger than this (memory and time)
  Status Validate() const;
};

// A coefficient set with its E (mm), as ranked.
struct ScoredSet {
  Coefficients set;
  double e = 0;
};

// Phase 1: every (N1Δμ, N2Δμ, N3Δη, N4Δη). Values are computed as (2N)·(Δ/2) so
// that Phase 2's half steps land on bit-identical values (duplicates are found).
std::vector<Coefficients> GridSets(const SearchOptions& o);
// Phase 2: every combination of {−Δ/2, 0, +Δ/2} per coefficient around each kept
// set; negative values dropped, duplicates listed once, in a deterministic order.
std::vector<Coefficients> RefinementSets(const std::vector<ScoredSet>& kept, const SearchOptions& o);
// The best `percent` % of the sets (at least one; ties broken by set order), best first.
// Sets with E = +inf are never kept.
std::vector<ScoredSet> SelectBest(const std::vector<Coefficients>& sets, const std::vector<double>& e, double percent);

enum class Phase3Method { kGrg, kSlsqp, kLbfgs, kBobyqa, kNelderMead, kNone };
const char* Phase3MethodName(Phase3Method m);
Result<Phase3Method> ParsePhase3Method(const std::string& name);

struct Phase3Options {
  Phase3Method method = Phase3Method::kGrg;
  GrgOptions grg;                 // also: fd_step and tolerances for the NLopt methods
  int max_evaluations = 400;      // per start, NLopt methods
  bool fix_scale = false;         // equality constraint: Σ μ/Δμ + η/Δη stays at the start's value
  // GRG: take the Gauss–Newton Jacobian from the simulator's forward sensitivities
  // when the evaluator has them (one evaluation per iterate instead of the 2n + 1 of
  // the central stencil). Default: on; off forces the stencil (for comparison).
  bool exact_jacobians = true;
  // GRG: after a first GRG at fixed scale, up to this many rounds of (search of the
  // scale ray, free GRG of round_iterations iterations). Inertia alone sets the
  // scale, and at a wrong scale the best ratios are biased, so the scale is searched
  // explicitly: a descent method barely moves along it (the Gauss–Newton model is
  // nearly singular there).
  int scale_rounds = 24;
  int round_iterations = 8;
  // Each round searches the scale within 10^±scale_search_decades of the current one:
  // a wide jump while the ratios are still off lets inertia compensate them at a wrong
  // scale (a false valley); narrow steps follow the true one.
  double scale_search_decades = 0.3;
  Status Validate() const;
};

struct PhaseSummary {
  std::string name;
  int64_t sets = 0;        // sets in the phase
  int64_t singular = 0;    // sets the solver could not simulate (E = +inf)
  ScoredSet best;
  double seconds = 0;
  std::string termination; // Phase 3: why the best start stopped
  std::string OneLineReport() const;
};

// Phase 3 from the given starts with the chosen method; evaluations go through
// `evaluator` (phase 3). Returns the best set found and the summary.
Result<ScoredSet> RunPhase3(const std::vector<ScoredSet>& starts, const SearchOptions& search,
                            const Phase3Options& opt, BatchEvaluator& evaluator, PhaseSummary* summary);

}  // namespace wormdrag
