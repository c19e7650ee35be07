// The stages of RunDiagnosis and the helpers they share. Private to core/diagnose:
// nothing outside it includes this header (the public interface is diagnosis.h).
//
// A diagnosis runs its stages in order on one DiagnosisRun, each filling in its part:
//   prepare.cc  PrepareRecordings  truncation, gaps, filter, noise σ, blocks, cautions
//   fit.cc      FitBase            the base fit and its refit on blocked paths
//   where.cc    MeasureWhere       the residual breakdown of the base fit
//   null.cc     MakeNullReplicates the noise-only recordings
//   cv.cc       CrossValidate      every model's two fold fits on the data and the nulls
//   cv.cc       RefitClosest       the leading effect refitted with free coefficients
//   null.cc     CheckSimex         the leading effects refitted on noisy copies
//   where.cc    AddNullToWhere     the breakdown's noise floor
//   cv.cc       CollectScores      the scores Decide needs, per effect
//   verdict.cc  Decide             (diagnosis.h) the verdict and "how far"
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "core/common/stats.h"
#include "core/diagnose/diagnosis.h"

namespace wormdrag::diagnose::internal {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kPi = 3.141592653589793;
// Grid units of the fit's coefficient variables (the paper's Δμ, Δη).
inline constexpr double kDMu = 0.1, kDEta = 1e-3;

// The sample mean and sd (n − 1; 0 for fewer than 2 values) of core/common/stats.h.
inline double Mean(const std::vector<double>& v) {
  return Summarize(v).mean;
}
inline double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
inline double Sd(const std::vector<double>& v) {
  return Summarize(v).sd;
}
// The (1 − alpha) prediction bound of a new draw from the noise-only replicates'
// positive values `null` (squared or root-mean-square distances), on a log scale: they
// are positive and skewed, their logarithms nearly normal. Infinite without two such
// values (verdict.cc; docs/decisions/0039-false-alarm-rate.md).
double NoiseBound(double alpha, const std::vector<double>& null);
// A CV score: the held-out MSE × (1 + kappa × extra parameters).
inline double Penalised(double mse, int p, double kappa) {
  return mse * (1 + kappa * p);
}

inline std::array<double, 4> ToUnits(const Coefficients& c) {
  return {c.mu_n / kDMu, c.mu_t / kDMu, c.eta_n / kDEta, c.eta_t / kDEta};
}
// In grid units, rescaled so that the four sum to `sum` (the overall scale is unobservable).
inline std::array<double, 4> UnitsAtSum(const Coefficients& c, double sum) {
  auto u = ToUnits(c);
  const double k = sum / std::max(1e-12, u[0] + u[1] + u[2] + u[3]);
  for (double& v : u) v *= k;
  return u;
}

// ---- Preparation (prepare.cc) ----

// Both recordings truncated to t_max and prepared (kept in `prepared_out` if given, at the
// full frame rate), and the data the fits use (EffectData::smoothing_change_rad set).
Result<EffectData> PreparePair(const std::array<Kinematics, 2>& raw, double t_max, const DiagnoseOptions& o,
                               const std::array<std::string, 2>& names,
                               std::array<Kinematics, 2>* prepared_out = nullptr);

// ---- Fitting (fit.cc) ----

// One simulation of a prepared recording under coefficients c and effects p; `blocked`
// restarts the pose at every block start.
EffectTrajectory Run(const EffectRecording& w, const Coefficients& c, const EffectParams& p, bool blocked, double eps);
// Further starts of an all-block fit that may have to move far from `around` (the blocked
// base refit, an effect's own refit): BaseStarts' corners and, after a GRG base fit, the
// user's start; none without base_multistart.
std::vector<Coefficients> FurtherStarts(const Coefficients& around, const DiagnoseOptions& o);

// ---- Cross-validation (cv.cc) ----

// A model's CV from its two fold fits: each block scored by the fold that did not train on it.
struct ModelCv {
  BlockScores held_out;
  double mse = kInf, e = kInf;
  std::vector<std::vector<double>> fold_params;
  std::vector<Coefficients> fold_coef;
  bool ok = false;
};
// All models' CV on one data set (the data or a null replicate).
struct CvSweep {
  ModelCv base;
  std::vector<ModelCv> effects;  // parallel to the tested list; !ok when untestable
};
ModelCv AssembleCv(const EffectData& d, const std::array<const FitOutcome*, 2>& folds, double eps);
// Both fold fits of a model ended at one of `starts` (EffectFit::estimated).
bool FoldsStayedAtStart(Effect e, const ModelCv& cv, const std::vector<std::vector<double>>& starts);
// An effect model contains the base model (the effect at its neutral value), so its fold
// fit can end above the base's training error on the same fold only if the optimiser got
// lost; then the base's fold fit with the effect neutral is the better point of the
// effect model, and it is used (DiagnoseOptions::nested_fallback).
bool LostToTheBase(const FitOutcome& effect_fit, const FitOutcome& base_fit);
FitOutcome BaseWithNeutralEffect(const FitOutcome& base_fit, Effect e);
// A fold fit of the CV: from `start`, held near it by the ridge, on blocks of `parity`.
FitSpec CvSpec(bool has_effect, Effect e, const Coefficients& start, double ridge_mm, int parity,
               const DiagnoseOptions& o);
std::vector<Effect> TestedEffects(const DiagnoseOptions& o);
// False (with a note) when the data cannot show the effect.
bool Testable(const EffectData& d, Effect e, std::string* note);

// ---- Noise-only replicates and SIMEX copies (null.cc) ----

// Noise-only replicate r ≥ 1 of the prepared truth (NullTruth) under the base `base`.
Result<EffectData> NullReplicate(const EffectData& data, const DiagnoseOptions& o, const Coefficients& base,
                                 double sigma, int r);
// The SIMEX check's noisy copy d of the recordings, prepared as the data are.
Result<EffectData> SimexCopy(const std::array<Kinematics, 2>& recordings, const DiagnoseOptions& o, double sigma,
                             int d);

// ---- Where (where.cc) ----

// The breakdowns' values (no null yet) and the residual per frame.
struct WhereValues {
  std::vector<Breakdown> breakdowns;
  std::vector<std::vector<double>> t, mm;
  double path_mse = 0;  // continuous path: mean squared distance over all points and valid frames, mm²
  GapSignature gap;     // gap_offset's mark in the same path's residual (gap_signature.h)
};
WhereValues ComputeWhere(const EffectData& d, const Coefficients& c, double eps, double gait_hz);

// ---- One diagnosis as its stages fill it in ----

struct DiagnosisRun {
  DiagnosisRun(const std::array<Kinematics, 2>& recordings, const std::array<std::string, 2>& names,
               const DiagnoseOptions& o);

  const std::array<Kinematics, 2>& recordings;
  const DiagnoseOptions& o;
  int threads = 1;
  Diagnosis out;

  // Preparation.
  double t_max = 0;                    // the analysed span: o.t_max, shortened to the recordings
  std::array<Kinematics, 2> prepared;  // at the full frame rate
  EffectData data;
  std::vector<Effect> tested;
  // The base fit refitted on blocked paths: start and ridge centre of the CV, truth of the nulls.
  Coefficients cv_base;
  double ridge_mm = 0;  // FitSpec::prior_weight of the CV's fold fits
  WhereValues where;
  // The data a FitTask's replicate index names: 0 the data, 1 … R the nulls, then the SIMEX copies.
  std::vector<EffectData> null_data, simex_data;
  std::vector<const EffectData*> replicate_data;

  // Cross-validation, per tested effect where indexed.
  CvSweep data_cv;
  std::vector<CvSweep> null_cv;
  std::vector<WhereValues> null_where;
  std::vector<FitOutcome> full;             // the reported coefficients and parameters
  std::vector<int> ranked;                  // testable effects, best CV score first
  std::vector<std::optional<ModelCv>> own;  // the refined effects' own fold fits
  std::vector<std::string> refit_note;
  std::vector<bool> own_unmoved;  // a refined effect's own fits all stayed at their starts
  std::vector<std::vector<double>> simex_mse, simex_own_mse;

  // Runs fits through o.run_fits, or on local threads. Local fits report their progress
  // under the stage of the last StartFits, counting up to its `total` (none before).
  Result<std::vector<FitOutcome>> RunFits(const std::vector<FitTask>& tasks);
  void StartFits(const std::string& stage, int total);
  void Progress(const std::string& stage, double fraction) const;
  bool Cancelled() const { return o.cancelled && o.cancelled(); }
  // The effects by penalised CV score, best first; with `refits`, an effect's own refit
  // counts where Decide counts it (DiagnoseOptions::score_refined_fit).
  std::vector<int> Rank(std::vector<int> v, const std::vector<std::optional<ModelCv>>* refits) const;

 private:
  Result<std::vector<FitOutcome>> RunLocally(const std::vector<FitTask>& tasks);
  std::atomic<int> fits_done_{0};
  int fits_total_ = 0;
  std::string fits_stage_ = "fits";
};

Status PrepareRecordings(DiagnosisRun* run);
Status FitBase(DiagnosisRun* run);
void MeasureWhere(DiagnosisRun* run);
Status MakeNullReplicates(DiagnosisRun* run);
Status CrossValidate(DiagnosisRun* run);
Status RefitClosest(DiagnosisRun* run);
Status CheckSimex(DiagnosisRun* run);
void AddNullToWhere(DiagnosisRun* run);
void CollectScores(DiagnosisRun* run);

}  // namespace wormdrag::diagnose::internal
