// The pair, its noise draws and the refits that replicate_bench's studies share: one
// benchmark pair (noise_bench's regimes and drives), each refit by Phase 3 from the truth.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "bench/shape_refit.h"
#include "core/common/status.h"
#include "core/diagnose/synth.h"
#include "core/estimate/paired_path.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::bench {

struct Setup {
  std::string regime, drive;
  int seed = 2;
  double noise_bl = 0.5;  // tracking noise, % BL
  Coefficients truth;
  Kinematics real;
  JobOptions options;
};

// The ratio the regime determines: K_μ agar-like, K_η water-like.
double Ratio(const Setup& s, const Coefficients& c);

// One noisy recording pair of the benchmark with its own noise seed, raw and clean.
Result<std::array<diagnose::SynthOutput, 2>> Draw(const Setup& s, int noise_seed);

// Both recordings smoothed with `options`, as the estimator smooths them.
Result<std::array<Kinematics, 2>> Smoothed(const std::array<Kinematics, 2>& k, const JobOptions& options);

// The pair of two recordings, each smoothed with `options` (or left as they are).
Result<std::shared_ptr<const PairedPath>> PairOf(const Setup& s, const std::array<Kinematics, 2>& k, bool smooth,
                                                 const JobOptions& options);

Result<Coefficients> Phase3FromTruth(const Setup& s, std::shared_ptr<const PairedPath> pair);
double FitFromTruth(const Setup& s, std::shared_ptr<const PairedPath> pair);  // the ratio; NaN on failure

// Fresh noise draw `i` of the pair, smoothed with `options` and fitted by Phase 3 from
// the truth: how the estimator's answer scatters around the truth.
double FreshDrawFit(const Setup& s, int i, const JobOptions& options);

// Replicate `i` made at the truth from the shapes of `from` (5 µm of noise), smoothed and
// refitted as the bootstrap refits it.
double TruthReplicateFit(const Setup& s, const PairedPath& from, int i);

// One Markdown row: the label and the values.
void PrintRow(const char* label, const std::vector<double>& v);

// Runs `n` jobs on both cores; job(i) returns one value. The values, sorted.
std::vector<double> Parallel(int n, const std::function<double(int)>& job);

// The single studies (replicate_bench's options of the same names; bench/replicate_studies.cc).
void ShapeRefitRow(const Setup& s, int n, const ShapeRefitOptions& options, bool from_truth);  // --shape-refit
void NoiseLadderRow(Setup s, int n, const std::vector<double>& levels);                        // --noise-ladder
Status ResemblanceRow(const Setup& s, int n);                                                  // --resemblance
void SimexRow(const Setup& s, int n, int copies);                                              // --simex
int LowpassTruthRows(const Setup& s, int n, const std::vector<double>& cutoffs);               // --lowpass-truths
int PredictedDetailRows(const Setup& s, int n, int harmonics);  // --predicted-detail (bench/predicted_detail.cc)

}  // namespace wormdrag::bench
