// The paper's three-phase search for (μ_n, μ_t, η_n, η_t) (docs/conventions.md §3, defaults from
// the paper's Table 1): a full grid, a local refinement around the best d1 %, and a
// GRG local optimisation from the best d2 % of the refinement.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/estimate/grg.h"
#include "core/estimate/paired_path.h"
#include "core/model/friction_law.h"

namespace wormdrag {

struct SearchOptions {
  int n_max = 10;                // Phase 1 grid N_i = 0 … n_max: (n_max+1)^4 sets
  double d_mu = 0.1;             // Δμ, µN
  double d_eta = 1e-3;           // Δη, µN·s/mm
  double d1 = 1.0;               // % of the grid kept for Phase 2
  double d2 = 0.2;               // % of the refinement kept for Phase 3
  int64_t max_sets = 2'000'000;  // refuse grids larger than this (memory and time)
  // Early abandoning in Phases 1–2 (docs/decisions/0001-early-abandoning.md). Default:
  // on, it simulates a fraction of the knots and keeps the same survivors with the same
  // E. Off: every set is simulated to its end in grid order and its E stored, which is
  // what the report's E slices over the Phase 1 grid need (an abandoned set has no E).
  bool abandon = true;
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
// Sets with E = +inf or kAbandoned are never kept.
std::vector<ScoredSet> SelectBest(const std::vector<Coefficients>& sets, const std::vector<double>& e, double percent);
// How many sets SelectBest keeps of `sets` when at least that many have an E.
int64_t KeepCount(size_t sets, double percent);

// The order in which early abandoning evaluates a phase, pass by pass (indices into the
// phase's sets; the passes together list every set once). The order changes which sets
// are abandoned, never the survivors: it puts the likely best first so that the cut
// tightens early, and neighbours together so that a batch's lanes stop together.
//  Phase 1: the coarse subgrid (every N_i even) …
std::vector<size_t> CoarseGridPass(const SearchOptions& o);
//  … then the rest, most promising first: each set ranked by the mean, over the corners
//  of the coarse cell it lies in, of min(E, cap), where cap is the keep-th smallest
//  coarse E and an abandoned or unsimulable corner counts as cap. Every abandoned
//  coarse set lies above cap, so this order does not depend on which ones were
//  abandoned. `e` is indexed like GridSets (only its coarse entries are read).
std::vector<size_t> FineGridPass(const SearchOptions& o, const std::vector<double>& e, int64_t keep);
//  Phase 2: the Phase 1 survivors themselves first (their E sets a tight cut at once),
//  then the rest in RefinementSets' order (grouped around the survivors, best first).
std::vector<size_t> RefinementPass(const std::vector<Coefficients>& refined, const std::vector<ScoredSet>& kept);

// One pass of a screening phase: from the values known so far (indexed like the
// phase's sets; +inf where not evaluated yet), the indices to evaluate next.
using ScreeningPass = std::function<std::vector<size_t>(const std::vector<double>& e)>;
// The passes of Phase 1 and Phase 2: the orders above with abandoning, else one pass
// in set order (exactly the evaluation without abandoning). Phase2Passes keeps
// references to `refined` and `kept`.
std::vector<ScreeningPass> Phase1Passes(const SearchOptions& o);
std::vector<ScreeningPass> Phase2Passes(const SearchOptions& o, const std::vector<Coefficients>& refined,
                                        const std::vector<ScoredSet>& kept);

enum class Phase3Method { kGrg, kSlsqp, kLbfgs, kBobyqa, kNelderMead, kNone };
const char* Phase3MethodName(Phase3Method m);
Result<Phase3Method> ParsePhase3Method(const std::string& name);

struct Phase3Options {
  Phase3Method method = Phase3Method::kGrg;
  GrgOptions grg;             // also: fd_step and tolerances for the NLopt methods
  int max_evaluations = 400;  // per start, NLopt methods
  bool fix_scale = false;     // equality constraint: Σ μ/Δμ + η/Δη stays at the start's value
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
  // The rounds end once one lowers f by less than round_chi2 · f / m (m residuals),
  // i.e. by less than round_chi2 in χ² were the whole misfit white noise. Past that
  // the rounds creep along the valley by steps the data cannot tell apart (on a noisy
  // replicate, tens of rounds of 1e-5 of f each while an undetermined ratio wanders).
  // Default: 1; 0 keeps them going while f falls by 1e-6 of itself.
  double round_chi2 = 1;
  // Each round searches the scale within 10^±scale_search_decades of the current one:
  // a wide jump while the ratios are still off lets inertia compensate them at a wrong
  // scale (a false valley); narrow steps follow the true one.
  double scale_search_decades = 0.3;
  Status Validate() const;
};

struct PhaseSummary {
  std::string name;
  int64_t sets = 0;       // sets in the phase
  int64_t singular = 0;   // sets the solver could not simulate (E = +inf), of those not abandoned
  int64_t abandoned = 0;  // sets stopped early: no E, proven not to survive
  // Solver knots (one set against one worm for one time step) simulated in this run,
  // and what simulating the same sets to their end would take (Phases 1–2; sets whose
  // stored E was reused count in neither).
  int64_t knots = 0, knots_full = 0;
  ScoredSet best;
  double seconds = 0;
  std::string termination;          // Phase 3: why the best start stopped
  std::string KnotsReport() const;  // "N abandoned, K of F knots simulated (P %)", "" without counts
  std::string OneLineReport() const;
};

// Phase 3 from the given starts with the chosen method; evaluations go through
// `evaluator` (phase 3). Returns the best set found and the summary.
Result<ScoredSet> RunPhase3(const std::vector<ScoredSet>& starts, const SearchOptions& search, const Phase3Options& opt,
                            BatchEvaluator& evaluator, PhaseSummary* summary);

}  // namespace wormdrag
