// Honest intervals for what the data determine (docs/estimation.md, "Intervals").
//
// A parametric bootstrap: the fitted model, driven by the recording's own smoothed
// shapes, is sampled at the recorded frames; Gaussian tracking noise of the SD
// estimated from the recording is added to every point; each replicate then goes
// through the same preprocessing as the data (resampling, smoothing chosen the same
// way) and is refitted. The spread of the refits measures what noise does to the
// estimate, bias included: the interval is the basic (reverse-percentile) bootstrap
// interval in log space, [θ̂² / q_hi, θ̂² / q_lo] for a ratio θ, which moves opposite
// to the refits' shift and so corrects a bias the replicates share with the data. Its
// quantiles q_lo, q_hi are taken at the plotting positions that make the interval hold
// a new draw of the refits' distribution as often as its level says.
// When the replicates carry more noise than the data (the noise floor below), the
// shift is scaled by the ratio of the noise variances, as a noise-induced bias scales:
// in log space the interval is θ̂ − s·b + [−(q_hi − m), m − q_lo], with m the refits'
// median, b = m − θ̂ their shift and s = min(1, σ_data² / σ_replicates²); s = 1 gives
// the basic interval.
//
// A combination is *determined* only when its interval is finite, touches no bound
// (no refit puts a coefficient of the ratio at 0) and spans at most `max_ratio`, and
// only when the data's E does not exceed every refit's (CheckMisfit).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/common/json.h"
#include "core/common/status.h"
#include "core/estimate/paired_path.h"
#include "core/model/friction_law.h"

namespace wormdrag {

struct BootstrapOptions {
  // Default: 20 replicates. The interval's ends are the refits' quantiles at the plotting
  // positions q (n + 1), so n refits give an interval of level (n − 1) / (n + 1) at most:
  // a 90 % interval needs 19 (MinReplicates). More narrow the interval's own noise (each
  // costs one Phase 3).
  int replicates = 20;
  // Default: 0.90, a two-sided 90 % interval.
  double level = 0.90;
  // Default: 2, an interval spanning more than a factor 2 says nothing a biologist
  // can use, so the combination is reported as not determined.
  double max_ratio = 2.0;
  // The replicates' noise is at least this share of the body length (%), whatever the
  // recording's own noise. Default: 0.05 % BL, about a tenth of a pixel at the usual
  // 100–200 px per body length, the best any tracker resolves: a clean simulation then
  // gets intervals that say what a real recording of it could determine, instead of
  // zero-width intervals around a fit whose residual bias (model mismatch) they miss.
  double noise_floor_percent_bl = 0.05;
  // A part of the friction law that contributes less than this share of the drag at
  // the body's median link speed is not determined, whatever its interval, and nor is
  // the crossover speed v_c between the parts. Default: 0.05. Its ratio then changes the path less than the other
  // part's noise does (a water-like fit with a trace of Coulomb friction has a K_μ, but no data set constrains it), and
  // a tight interval would say otherwise.
  double min_force_share = 0.05;
  // The check of each determined combination (core/jobs/bootstrap_run.h): this many
  // refits at each of its corrected value × and ÷ `check_factor`. Default: 8 and 1.5:
  // a value 1.5 times away that the data cannot exclude makes the interval span at
  // least 1.5² > max_ratio; eight refits span the central ~80 % of their spread.
  // 0 refits: no check (the basic interval alone).
  int check_replicates = 8;
  double check_factor = 1.5;
  // The smoothing check (core/jobs/bootstrap_run.h), before the check above: the data
  // refitted with the λ of their shape smoothing divided and multiplied by this
  // factor. A determined combination's interval is widened to hold both refits
  // (bias-corrected as the interval is), and the max_ratio rule applies again: the
  // replicates, made from the smoothed shapes, do not carry the shape detail the
  // smoothing may have removed, so the choice of λ is a systematic of its own.
  // Default: 10, a decade either way, wider than GCV's own spread of λ between noise
  // draws of one recording (an SD of 0.05–0.3 in log₁₀ for the modes that carry
  // shape; decision 0031). 0: no check.
  double smoothing_check = 10;
  uint64_t seed = 1;  // replicate r uses seed + r: reproducible and independent of threads
  Status Validate() const;
};

// The fewest replicates whose quantiles make an interval of this level: the smallest n
// with (n − 1) / (n + 1) ≥ level (19 at 0.90, 39 at 0.95).
int MinReplicates(double level);

struct CombinationInterval {
  std::string name;     // "K_mu", "K_eta", "v_c", "scale"
  double estimate = 0;  // at the fit
  // The fit corrected for the bias the replicates show (the centre of the basic
  // interval): what to report when determined. Equal to `estimate` when undefined.
  double corrected = 0;
  double lo = 0, hi = 0;  // the interval (0 or +inf where it touches a bound)
  bool determined = false;
  std::string why;  // when not determined: in words
};

// One line of the intervals' text: the corrected value and interval when determined,
// else "not determined" and why. Shared by BootstrapReport::ToText and readers of
// stored results.
std::string IntervalLine(const CombinationInterval& c);

// The goodness-of-fit line: the data's E beside the range of the refits' and whether it
// lies above all of them ("" without refits). Shared like IntervalLine.
std::string MisfitLine(double data_e, const std::vector<double>& fit_e);

struct BootstrapReport {
  int replicates = 0;  // refits that finished
  int failed = 0;      // replicates whose refit failed (not in the intervals)
  double level = 0.9;
  std::array<double, 2> noise_mm{};  // the SD used per worm
  std::vector<Coefficients> fits;    // the refits, in replicate order
  CombinationInterval K_mu, K_eta, v_c, scale;
  int check_refits = 0;  // refits spent checking determined combinations
  // Each group of the check: the combination, the value its replicates were made with,
  // and the range of their finished refits (lo > hi: none finished).
  struct CheckGroup {
    std::string name;
    double value = 0, lo = 0, hi = 0;
  };
  std::vector<CheckGroup> checks;
  // Goodness of fit: the data's E at the fit and each finished refit's E against its
  // replicate (as `fits`). Replicates carry tracking noise and nothing else the model
  // lacks, so when the data's E exceeds every refit's, part of the data's misfit is not
  // tracking noise, the replicates do not describe the data's errors, and no
  // combination is determined (CheckMisfit).
  double data_e = 0;
  std::vector<double> fit_e;
  bool misfit_explained = true;
  double link_speed = 0;  // the recordings' median link speed, mm/s (0: unknown)
  // The smoothing check's refits of the data: the λ scale and the refit (nullopt: failed).
  std::vector<std::pair<double, std::optional<Coefficients>>> smoothing_fits;
  Json ToJson() const;
  std::string ToText() const;
};

// One replicate pair: the model with coefficients `c` driven by `pair`'s (smoothed)
// shapes, sampled at the scored span's frames (missing frames stay missing), with
// N(0, noise_mm[j]²) added to both coordinates of every point, and each frame
// resampled by arc length as the file reader does. Deterministic in `seed`.
Result<std::array<Kinematics, 2>> MakeReplicate(const PairedPath& pair, const Coefficients& c,
                                                const std::array<double, 2>& noise_mm, uint64_t seed);

// The scale of a set, as the fixed-scale constraint of Phase 3 measures it:
// Σ μ/Δμ + η/Δη.
double CoefficientScale(const Coefficients& c, double d_mu, double d_eta);

// The intervals from the refits (`ok[r]` false: replicate r failed).
// `bias_share` is s above; `link_speed` (mm/s) the recordings' median link speed for
// `min_force_share` (0: not applied).
BootstrapReport SummariseBootstrap(const Coefficients& estimate, const std::vector<Coefficients>& fits,
                                   const std::vector<bool>& ok, double d_mu, double d_eta, const BootstrapOptions& opt,
                                   double bias_share = 1.0, double link_speed = 0);

// In a law whose Coulomb and viscous parts each carry at least `min_force_share` of
// the drag at the median link speed (report->link_speed), K_μ describes one part and
// K_η the other, and v_c says how the drag divides between them. When v_c is not
// determined, neither ratio is: a fit that puts the crossover too high or too low
// answers with a ratio moved the other way, and the replicates, made at that fit, do
// not show it (decision record 0044). Called by SummariseBootstrap and again once the
// checks have run, since they may leave v_c not determined.
void RequireCrossover(const Coefficients& estimate, const BootstrapOptions& opt, BootstrapReport* report);

// The goodness-of-fit test: records the data's E and the refits' E (`fit_e`, one per
// finished refit, as report->fits) and, when the data's E exceeds all of them, marks
// every combination not determined. Were the model right up to tracking noise, the
// data's E would be one more draw beside the refits', above all n of them with
// probability 1/(n + 1) (under 5 % with 20 replicates).
void CheckMisfit(double data_e, const std::vector<double>& fit_e, BootstrapReport* report);

}  // namespace wormdrag
