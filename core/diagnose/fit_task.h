// The units of work of a diagnosis: a recording prepared for effect fits, one fit's
// specification and outcome, and the held-out scores of a model. Every fit of a
// diagnosis is one FitTask, so the fits can run on local threads or on the service's
// workers; the benchmark and tests use these pieces directly.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "core/common/status.h"
#include "core/diagnose/effect_sim.h"
#include "core/diagnose/effects.h"
#include "core/estimate/paired_path.h"
#include "core/io/kinematics.h"

namespace wormdrag::diagnose {

// A recording prepared for effect fits: its drive, scored frames and time blocks.
struct EffectRecording {
  std::shared_ptr<const EffectDrive> drive;
  Kinematics kinematics;  // prepared (filtered, truncated); missing frames unscored
  struct Scored {
    int frame;  // recording frame
    int block;
    std::vector<Vec2> measured;  // per evaluation point, lab frame
    std::vector<Vec2> model;     // head frame
  };
  std::vector<Scored> frames;
  std::vector<int> block_starts;  // recording frames where blocks 1… start (pose resets)
  // With a subsampled fit (fit_hz): the full-rate prepared recording and, per frame of
  // `kinematics`, the index of its source frame in `full` (both empty otherwise).
  Kinematics full;
  std::vector<int> source_frames;
  // The prepared recording at the full frame rate, subsampled fit or not.
  const Kinematics& FullRate() const { return source_frames.empty() ? kinematics : full; }
};
struct EffectData {
  std::array<EffectRecording, 2> worms;
  double body_length = 0;
  int blocks = 0;
  // RMS change (rad) the smoothing made to the joint angles of the valid frames (0 when
  // unsmoothed). Beyond a noise-only replicate's, it is motion the smoothing took for
  // noise, which the drive loses and no catalogue effect restores ("where", smoothing).
  double smoothing_change_rad = 0;
};
// From kinematics already filtered and truncated to the analysed span; fit_hz > 0
// subsamples the frames as DiagnoseOptions::fit_hz describes.
Result<EffectData> PrepareEffectData(const std::array<Kinematics, 2>& k, const std::vector<int>& points, int substeps,
                                     int blocks, double fit_hz = 0);

// The frames a fit at `fit_hz` keeps (indices into k.frames): every
// round(fps / fit_hz)-th frame, every valid frame next to a missing one, the first
// missing frame of each run, and the last frame. All frames when fit_hz <= 0 or the
// stride is 1.
std::vector<int> FitFrames(const Kinematics& k, double fit_hz);

struct FitSpec {
  bool has_effect = false;
  Effect effect = Effect::kBodyGradient;
  std::vector<std::vector<double>> effect_starts;  // starting parameter vectors (per_worm: one set or both worms')
  Coefficients start;
  // Further coefficient starts, run in lockstep with `start` and pruned (each is
  // rescaled to start's coefficient sum: the overall scale is unobservable, §2).
  std::vector<Coefficients> extra_starts;
  // Ridge toward `prior`: one residual prior_weight × ln((u + δ) / (u_prior + δ)) per
  // coefficient (u in grid units at start's coefficient sum, δ = 2 % of that sum). It
  // keeps a fit on half the blocks from wandering along the valley of nearly equivalent
  // coefficient sets (DiagnoseOptions::cv_ridge). 0 = none.
  Coefficients prior;
  double prior_weight = 0;  // mm (the residuals are distances)
  bool blocked = true;      // pose restarts at block starts
  int train_parity = -1;    // fit on blocks with block % 2 == parity; -1 = all
  int iterations = 25;
  double epsilon = kDefaultEpsilon;
  int threads = 1;
  // Jacobian by forward differences (n + 1 simulations per iteration instead of
  // 2n + 1); Gauss–Newton converges as well with it on these fits
  // (docs/decisions/0012-fit-time-resolution.md).
  bool forward_differences = true;
  // The effect's parameters fitted separately for each worm (2 × its count; the
  // coefficients stay shared): does an effect of the medium act alike on both worms?
  // A measurement (`diagnose_bench --worm-check`); the diagnosis does not use it: the
  // split does not separate a tether from a true time_drift
  // (docs/decisions/0028-removed-experiments.md).
  bool per_worm = false;
};
struct FitOutcome {
  Coefficients coef;
  EffectParams effects;              // worm 1's when per_worm
  EffectParams second_worm_effects;  // worm 2's when per_worm (neutral otherwise)
  std::vector<double> params;        // per_worm: worm 1's, then worm 2's
  double train_mse = 0;
  long evaluations = 0;
};
// One fit of a diagnosis: on the data (replicate 0), or on noise-only replicate r ≥ 1
// simulated from `null_base` with tracking noise `null_sigma` (FitTaskData). The
// fits of a diagnosis are independent of each other once the base fit is known, so
// they can run anywhere: on local threads, or as tasks on the service's workers.
struct FitTask {
  int replicate = 0;
  Coefficients null_base;
  double null_sigma = 0;
  FitSpec spec;
};
// Runs fits and returns their outcomes in the order given.
using FitRunner = std::function<Result<std::vector<FitOutcome>>(const std::vector<FitTask>&)>;

// Fits spec's model (base, or base plus its effect) to `data` by Gauss–Newton GRG,
// on the training blocks spec.train_parity selects.
Result<FitOutcome> FitModel(const EffectData& data, const FitSpec& spec);

// Sums of distances and squared distances over the frames of the given blocks
// (parity −1: all), per block, for a model.
struct BlockScores {
  std::vector<double> sum, sum_sq;  // per (worm, block): index worm * blocks + block
  std::vector<int> count;
};
BlockScores ScoreBlocks(const EffectData& data, const Coefficients& c, const EffectParams& p, bool blocked,
                        double epsilon);

}  // namespace wormdrag::diagnose
