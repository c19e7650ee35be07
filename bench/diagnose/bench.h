// The diagnosis benchmark's shared parts: its synthetic cases, the outcome of a diagnosis
// of one, how a set is scored, the saved state of outcomes, and the modes (main.cc
// dispatches to one per run; each check has its own file). docs/diagnose.md, "Benchmark".
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/common/flags.h"
#include "core/common/json.h"
#include "core/diagnose/diagnosis.h"
#include "core/sim/pattern.h"

namespace wormdrag::diagnose_bench {

using namespace wormdrag::diagnose;

// ---- Command line (the last occurrence of an option wins, so that
// `diagnose_bench $F --jobs 2` overrides F's --jobs 1). `name` is the option as
// written, "--fps"; a value that is no number reads as 0, as atof reads it. ----
std::string ArgS(const flags::Args& args, const char* name, const std::string& fb);
double Arg(const flags::Args& args, const char* name, double fb);
bool Flag(const flags::Args& args, const char* name);
// Creates the folder a file is to be written into (the outputs default to build/).
void CreateParentFolder(const std::string& path);

// ---- Cases (cases.cc) ----

// A seed set's generator family follows from its number. Sets below 200 are the standard
// family: the bench's --fps, --duration and --noise for every pair, Coulomb-dominated
// friction, pattern and kymogram pairs in turn. In the others every pair draws its own
// frame rate (30–300 fps, log-uniform), length (2–10 s; kymogram pairs at most 9 s, what
// the delta-turn kymogram holds), noise (1–5 µm) and friction regime, and one drive makes
// them all: 200–299 the paper's patterns, 300–399 the kymograms, 400–499 travelling waves
// with amplitude envelopes drawn per worm (docs/diagnose.md, "Benchmark").
enum class Family { kStandard, kPattern, kKymogram, kEnvelope };
Family FamilyOfSet(uint64_t set_seed);
const char* FamilyName(Family f);

struct Case {
  std::string category;  // none, catalogue, outside
  std::string effect;    // truth name ("none" for controls)
  int strength = 0;      // 0 weak, 1 medium, 2 strong
  EffectParams truth;
  Coefficients coef;
  int source = 0;  // 0 pattern pair, 1 kymogram pair, 2 envelope-wave pair
  uint64_t seed = 0;
  Family family = Family::kStandard;
  // "coulomb" (Coulomb friction dominates at the body's speeds) or "viscous" (none).
  std::string regime = "coulomb";
  // The pair's own conditions in a family set; 0 in the standard family, whose pairs take
  // the bench's.
  double fps = 0, duration = 0, noise = 0;
  std::array<JointPattern, 2> waves;  // the envelope family's drives
};
// The 44 cases of seed set `set_seed`: 11 `none`, every catalogue effect at three
// strengths, the three outside effects at three strengths. Case i has seed set × 1000 + i.
std::vector<Case> MakeCases(uint64_t set_seed);
// Case `index` of a set of `family` (its effect, coefficients and seed already set) gets
// the family's drive and draws its conditions (families.cc).
void DrawConditions(Family family, int index, Case* c);
// One benchmark case by its seed; false if the seed names no case.
bool CaseBySeed(uint64_t seed, Case* c);

// The kymogram shapes of the kymogram pairs, and the period of the pairs' dropped-frame
// runs in s (--gap-every; 0 = no dropped frames).
struct Sources {
  Kinematics omega, delta;
  double gap_every_s = 0.25;
};
// The kymograms, their joint angles low-passed at `cutoff_hz` first (0 = raw): the
// kymograms carry content above the diagnosis's 5 Hz low-pass, which would drive the truth
// in ways the processed drive cannot follow (docs/decisions/0026-benchmark-kymogram-cutoff.md).
Result<Sources> LoadSources(double cutoff_hz);
// A case's pair of recordings with tracking noise `noise` (mm per coordinate). A family
// case is recorded at its own frame rate and length, and with its own noise unless
// `noise` is 0 (the clean pair).
Result<std::array<Kinematics, 2>> Synth(const Case& c, const Sources& src, double fps, double duration,
                                        double noise = 0.002, uint64_t noise_seed_offset = 0);
// The frame rate, length and tracking noise a case is recorded with: its own in a family
// set, else the bench's.
double FpsOf(const Case& c, double fps);
double DurationOf(const Case& c, double duration);
double NoiseOf(const Case& c, double noise);
// A case's drive in words: "pattern", "kymogram" or "envelope".
const char* SourceName(const Case& c);

struct Outcome {
  Case c;
  Diagnosis d;
  double e_true = 0;    // held-out E of the true model
  double mse_true = 0;  // its held-out mean squared distance (mm²)
  // Held-out MSE of the true effect's model fitted as the diagnosis fits it, but started
  // from the truth (FittedTruth); < 0 when not measured.
  double mse_fitted_truth = -1;
  double e_fitted_truth = 0;
  double seconds = 0;
  bool ok = false;
  std::string error;
};
// One case diagnosed, with its true model's and fitted truth's held-out scores.
Outcome RunCase(const Case& c, const Sources& src, const DiagnoseOptions& o, double fps, double duration,
                double noise = 0.002);
// Held-out E of the TRUE model (its known coefficients and effect, nothing fitted) on
// prepared data, blocked as the CV scores; *mse gets its mean squared distance.
double TrueModelE(const EffectData& d, const Case& c, double eps, double* mse = nullptr, bool blocked = true);
// The true effect's model fitted on each fold as the diagnosis's CV fits an effect but
// started from the truth; its held-out E and MSE. False if a fold's fit fails.
bool FittedTruth(const EffectData& d, const Case& c, double noise_sigma, const DiagnoseOptions& o, double* e,
                 double* mse);
// gap_offset's a fitted with all blocks (coefficients free) from coefficients `c`: how far
// a model driven by processed shapes falls behind.
double GapOffsetFrom(const EffectData& d, const Coefficients& c, const DiagnoseOptions& o);
// Noise-only replicate `r` of a prepared pair under `c` (both worms), not yet filtered.
Result<std::array<Kinematics, 2>> NullPair(const EffectData& d, const Coefficients& c, double eps, double sigma, int r);

// ---- Saved outcomes (state.cc): one JSON line per outcome, what Decide and the report
// need, so that rules can be re-tuned and re-scored without running the fits again ----
nlohmann::json StateOf(const std::string& set, const Outcome& x);
// A line of a state file; false if its seed names no case. Throws nlohmann::json::exception
// on a missing or mistyped field.
bool OutcomeOf(const nlohmann::json& j, Outcome* out);
// An outcome in brief (a line of the --out file, and --case).
wormdrag::Json SummaryJson(const Outcome& x);

// ---- Scoring (score.cc) ----

struct Score {
  double catalogue_correct = 0, strong_correct = 0, above_correct = 0, none_fp = 0, outside_unexplained = 0,
         outside_named = 0, outside_clear = 0;
  // Named verdicts (an effect or a set) by their confidence (Diagnosis::confidence):
  // how many, and how many right (the truth in the verdict set).
  int clear = 0, clear_right = 0, tentative = 0, tentative_right = 0;
  int n_above = 0;
  double above_fitted_correct = 0;  // the same against AboveFittedThreshold
  int n_above_fitted = 0;
  double objective = 0;
};
// Decides every outcome with `o` and scores them.
Score Evaluate(std::vector<Outcome>& v, const DiagnoseOptions& o);
// The tables of one scored set: rates, confusion matrix, every catalogue case, the
// shrink, the SIMEX check.
void PrintSet(const char* title, const std::vector<Outcome>& v, const Score& s, const DiagnoseOptions& best);

// ---- Modes ----

// What every mode shares: the command line, the diagnosis options built from it, the
// pairs' frame rate and length, and the kymogram sources.
struct Bench {
  flags::Args args;
  DiagnoseOptions o;
  double fps = 100, duration = 3;
  std::string out_path;  // --out: the summary lines; FILE.state the outcomes
  Sources src;
  // The options with the low-pass whatever --smoothing says: for the studies of its
  // cut-offs (drive, null-drive and truth checks).
  DiagnoseOptions LowpassOptions() const {
    DiagnoseOptions l = o;
    l.smoothing = SmoothingMethod::kLowpass;
    return l;
  }
};
int RunSets(const Bench& b);  // sets.cc: tune on one seed set, score another, or --redecide
// The benchmark case named by `flag`'s seed and its pair with --noise (default 2 µm):
// 0, or the exit code after saying why not.
int SynthCaseOf(const Bench& b, const char* flag, Case* c, std::array<Kinematics, 2>* ks);
int RunOneCase(const Bench& b);  // case.cc: --case SEED
int RunSingle(const Bench& b);   // case.cc: --single
int TruthCheck(const Bench& b);
int NoiseCheck(const Bench& b);
int ProfileCheck(const Bench& b);
int GapCheck(const Bench& b);
int SimexCheck(const Bench& b);
int ResolutionCheck(const Bench& b);
int DriveCheck(const Bench& b);
int NullDriveCheck(const Bench& b);
int NullCheck(const Bench& b);
int NullTruthCheck(const Bench& b);
int StrengthCheck(const Bench& b);  // strength_check.cc: --strength-check
// The p-value of `data` among replicates of it, by rank: (1 + #{r ≥ data}) / (n + 1).
double RankPValue(double data, const std::vector<double>& reps);
// One line: the shares of p-values at or below 0.05, 0.1 and 0.5, the Kolmogorov–Smirnov
// distance of their distribution from the uniform, and the sorted values.
void PrintPValueShares(const std::string& name, std::vector<double> p);
int FitCheck(const Bench& b);
int WormCheck(const Bench& b);
int FoldCheck(const Bench& b);

// The pair of --gap-check and --simex: a benchmark case (--case SEED, tracking noise
// --noise, its truth's coefficients unless --coef gives others) or two recordings
// (--files K1.csv,K2.csv with --coef MU_N,MU_T,ETA_N,ETA_T). On failure prints why and
// returns the exit code (else 0).
struct LoadedPair {
  Case c;  // effect "recorded" for files
  Coefficients coef{};
  std::array<Kinematics, 2> k;
};
int LoadPair(const Bench& b, const char* mode, LoadedPair* out);

}  // namespace wormdrag::diagnose_bench
