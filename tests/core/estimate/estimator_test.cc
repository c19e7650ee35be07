#include "core/estimate/estimator.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

const Coefficients kTruth{0.55, 0.25, 0.006, 0.003};

Kinematics Loco(int index, const Coefficients& c, double fps = 300, double duration = 2) {
  SimOptions sim;
  RecordingSpec spec;
  spec.fps = fps;
  spec.duration = duration;
  spec.substeps = EvaluationOptions().SubstepsFor(fps);
  spec.as_estimated = true;  // the paper's verification: one simulator for data and fit
  auto k = GenerateRecording(Locomotion(index), c, sim, spec);
  EXPECT_TRUE(k.ok());
  return *k;
}

EvaluationOptions ShortEval() {
  EvaluationOptions e;
  e.t_max = 2;
  return e;
}

std::shared_ptr<const PairedPath> Pair(const Coefficients& c, EvaluationOptions e = ShortEval()) {
  auto p = PairedPath::Create({Loco(1, c), Loco(2, c)}, {"L1", "L2"}, e);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return *p;
}

TEST(Evaluation, ZeroAtTheTruthAndPositiveElsewhere) {
  auto pair = Pair(kTruth);
  LocalEvaluator ev(pair, 2);
  std::vector<double> e;
  ASSERT_TRUE(ev.Evaluate({kTruth, kTruth.Scaled(3), {0.25, 0.55, 0.003, 0.006}, {0, 0, 0, 0}}, &e).ok());
  const double L = pair->mean_body_length();
  EXPECT_LT(e[0] / L, 1e-7);         // only the difference of generation and evaluation steps
  EXPECT_LT(e[1] / L, 1e-4);         // scale: inertia only
  EXPECT_GT(e[2] / L, 1e-2);         // a different anisotropy moves the worm elsewhere
  EXPECT_TRUE(std::isfinite(e[3]));  // no friction: the inertial body coasts
  EvaluationOptions qs = ShortEval();
  qs.sim.solver = Solver::kQuasiStatic;
  LocalEvaluator qev(Pair(kTruth, qs), 1);
  ASSERT_TRUE(qev.Evaluate({{0, 0, 0, 0}, kTruth}, &e).ok());
  EXPECT_FALSE(std::isfinite(e[0]));  // without inertia it cannot be simulated
  EXPECT_LT(e[1] / L, 3e-5);          // the data were made with inertia: only its lag differs
}

TEST(Evaluation, MissingFramesAreNotScored) {
  Kinematics a = Loco(1, kTruth), b = Loco(2, kTruth);
  auto full = PairedPath::Create({a, b}, {"a", "b"}, ShortEval());
  for (int f = 150; f < 160; ++f) a.frames[f].valid = false;
  auto gappy = PairedPath::Create({a, b}, {"a", "b"}, ShortEval());
  ASSERT_TRUE(full.ok() && gappy.ok());
  EXPECT_EQ((*full)->scored_count() - (*gappy)->scored_count(), 10 * 3);
}

TEST(Evaluation, BadInput) {
  const Kinematics a = Loco(1, kTruth), b = Loco(2, kTruth);
  EvaluationOptions e = ShortEval();
  e.t_max = 5;
  auto shorter = PairedPath::Create({a, b}, {"K1.csv", "K2.csv"}, e);
  ASSERT_FALSE(shorter.ok());
  EXPECT_NE(shorter.status().message().find("K1.csv: the recording is 2 s long, shorter than t_max = 5 s"),
            std::string::npos)
      << shorter.status().message();
  Kinematics big = b;
  for (auto& f : big.frames) {
    for (auto& p : f.p) p *= 1000;  // µm read as mm
    f.arc_length *= 1000;
  }
  auto mixed = PairedPath::Create({a, big}, {"K1.csv", "K2.csv"}, ShortEval());
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.status().message().find("different body models"), std::string::npos);
  e = ShortEval();
  e.points = {3, 14};
  EXPECT_FALSE(PairedPath::Create({a, b}, {"a", "b"}, e).ok());
  e = ShortEval();
  e.substeps = -1;
  EXPECT_FALSE(PairedPath::Create({a, b}, {"a", "b"}, e).ok());
}

// A 6⁴ grid over the same span as the paper's, for tests that run the whole estimate.
EstimateOptions SmallGrid() {
  EstimateOptions o;
  o.eval = ShortEval();
  o.search.n_max = 5;
  o.search.d_mu = 0.2;
  o.search.d_eta = 0.002;
  o.search.d1 = 2;
  o.search.d2 = 2;
  return o;
}

TEST(Estimator, RecoversIdentifiableCombinations) {
  EstimateOptions o = SmallGrid();
  auto pair = Pair(kTruth, o.eval);
  auto screening = PairedPath::Create({pair->worm(0).kinematics, pair->worm(1).kinematics}, {"L1", "L2"},
                                      o.ScreeningEval());
  ASSERT_TRUE(screening.ok());
  LocalEvaluator fast(*screening, 2), accurate(pair, 2);
  int survivor_calls = 0;
  EstimateHooks hooks;
  hooks.survivors = [&](int, const std::vector<ScoredSet>& r) {
    ++survivor_calls;
    EXPECT_FALSE(r.empty());
    return Status::Ok();
  };
  struct Event {
    int64_t done, total;
    double best_e;
  };
  std::vector<std::pair<std::string, Event>> last;  // each stage's last progress event, in order
  hooks.progress = [&](const std::string& phase, int64_t done, int64_t total, double best_e) {
    if (last.empty() || last.back().first != phase) last.push_back({phase, {}});
    last.back().second = {done, total, best_e};
  };
  auto r = RunEstimate(fast, accurate, o, pair->mean_body_length(), hooks);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  std::printf("%s", r->ToText().c_str());
  EXPECT_EQ(survivor_calls, 2);
  // Every stage ends complete, so a progress line or a watcher never shows a finished
  // stage as "0 of N"; the last one carries the final E.
  ASSERT_EQ(last.size(), 4u);
  const char* stages[] = {"phase1", "phase2", "phase3", "identifiability"};
  for (size_t i = 0; i < last.size(); ++i) {
    EXPECT_EQ(last[i].first, stages[i]);
    EXPECT_EQ(last[i].second.done, last[i].second.total) << last[i].first;
  }
  EXPECT_EQ(last[2].second.done, r->phase3.sets);
  EXPECT_EQ(last[3].second.best_e, r->best.e);
  EXPECT_EQ(r->phase1.sets, 1296);
  EXPECT_NEAR(r->best.set.K_mu() / kTruth.K_mu(), 1, 0.01);
  EXPECT_NEAR(r->best.set.K_eta() / kTruth.K_eta(), 1, 0.01);
  EXPECT_NEAR(r->best.set.v_c() / kTruth.v_c(), 1, 0.01);
  EXPECT_LT(r->e_percent, 0.03);
  // Noise-free data carry the inertial signal, but far below what tracking resolves:
  // the report must say the scale is not determined.
  EXPECT_FALSE(r->identifiability.scale_determined);
  EXPECT_NE(r->identifiability.plain_language.find("scale of the four coefficients is NOT determined"),
            std::string::npos);
  EXPECT_EQ(r->identifiability.eigenvalues.size(), 4u);
}

// Phase 1 + 2 as a plain loop: every set simulated to its end, in set order, no cut.
std::vector<ScoredSet> PlainPhase(const PairedPath& pair, const std::vector<Coefficients>& sets, double percent) {
  EvaluationWorkspace ws;
  std::vector<double> e(sets.size());
  for (size_t i = 0; i < sets.size(); i += kLanes)
    EvaluateLanes(pair, &sets[i], static_cast<int>(std::min<size_t>(kLanes, sets.size() - i)), Objective::kMeanDistance,
                  ws, &e[i]);
  return SelectBest(sets, e, percent);
}

void ExpectSameSurvivors(const std::vector<ScoredSet>& a, const std::vector<ScoredSet>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].set, b[i].set) << what << " rank " << i;
    EXPECT_EQ(a[i].e, b[i].e) << what << " rank " << i;  // the same double
  }
}

TEST(Estimator, EarlyAbandoningKeepsTheSurvivorsBitForBit) {
  EstimateOptions o = SmallGrid();
  o.search.d2 = 1;
  o.phase3.method = Phase3Method::kNone;
  auto pair = Pair(kTruth, o.eval);
  auto screening = PairedPath::Create({pair->worm(0).kinematics, pair->worm(1).kinematics}, {"L1", "L2"},
                                      o.ScreeningEval());
  ASSERT_TRUE(screening.ok());
  // The reference: the plain loop.
  const auto grid = GridSets(o.search);
  const auto ref1 = PlainPhase(**screening, grid, o.search.d1);
  const auto ref2 = PlainPhase(**screening, RefinementSets(ref1, o.search), o.search.d2);
  for (bool abandon : {true, false})
    for (int threads : {1, 2}) {
      o.search.abandon = abandon;
      LocalEvaluator fast(*screening, threads), accurate(pair, threads);
      auto r = RunEstimate(fast, accurate, o, pair->mean_body_length());
      ASSERT_TRUE(r.ok()) << r.status().ToString();
      const std::string what = std::string(abandon ? "abandoning" : "full grid") + ", " + std::to_string(threads) +
                               " threads";
      ExpectSameSurvivors(r->survivors1, ref1, what + ", phase 1");
      ExpectSameSurvivors(r->survivors2, ref2, what + ", phase 2");
      std::printf("%s:\n  %s\n  %s\n", what.c_str(), r->phase1.OneLineReport().c_str(),
                  r->phase2.OneLineReport().c_str());
      for (const PhaseSummary* p : {&r->phase1, &r->phase2}) {
        EXPECT_EQ(p->knots_full, p->sets * (*screening)->knots_per_set());
        if (abandon) {
          EXPECT_GT(p->abandoned, 0) << p->name;  // or the comparison above proves nothing
          EXPECT_LT(p->knots, p->knots_full / 2) << p->name;
        } else {
          EXPECT_EQ(p->abandoned, 0);
          EXPECT_EQ(p->knots, p->knots_full);
        }
      }
      EXPECT_EQ(r->phase1.best.set, ref1[0].set);
    }
}

TEST(Estimator, CancelStopsTheRun) {
  EstimateOptions o;
  o.eval = ShortEval();
  auto pair = Pair(kTruth, o.eval);
  LocalEvaluator ev(pair, 1);
  EstimateHooks hooks;
  hooks.cancelled = [] { return true; };
  auto r = RunEstimate(ev, ev, o, pair->mean_body_length(), hooks);
  EXPECT_EQ(r.status().code(), Status::Code::kCancelled);
}

// The grid holds no law between pure viscous drag and v_c = Δμ / (N_max Δη), here
// 20 mm/s, so a mixed law at the body's speeds (v_c = 0.5 mm/s) is reachable only in
// Phase 3. From the Coulomb-dominated survivors alone GRG ends on another law; the
// viscous start reaches the truth.
TEST(Estimator, FindsAMixedLawBetweenTheGridsLaws) {
  const Coefficients mixed{0.006, 0.0015, 0.006, 0.003};
  EstimateOptions o = SmallGrid();
  const Kinematics k3 = Loco(3, mixed, 100), k4 = Loco(4, mixed, 100);
  auto pair = PairedPath::Create({k3, k4}, {"L3", "L4"}, o.eval);
  auto screening = PairedPath::Create({k3, k4}, {"L3", "L4"}, o.ScreeningEval());
  ASSERT_TRUE(pair.ok() && screening.ok());
  LocalEvaluator fast(*screening, 2), accurate(*pair, 2);
  auto r = RunEstimate(fast, accurate, o, (*pair)->mean_body_length());
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  for (const ScoredSet& s : r->survivors2) EXPECT_GT(s.set.mu_n + s.set.mu_t, 0);  // no viscous survivor
  EXPECT_NEAR(r->best.set.K_mu() / mixed.K_mu(), 1, 0.01);
  EXPECT_NEAR(r->best.set.K_eta() / mixed.K_eta(), 1, 0.01);
  EXPECT_NEAR(r->best.set.v_c() / mixed.v_c(), 1, 0.01);
  PhaseSummary summary;
  auto alone = RunPhase3(r->survivors2, o.search, o.phase3, accurate, &summary);
  ASSERT_TRUE(alone.ok());
  std::printf("survivors alone: %s E %.3g mm; with the viscous start E %.3g mm\n", alone->set.ToString().c_str(),
              alone->e, r->best.e);
  EXPECT_GT(alone->e, 100 * r->best.e);
}

}  // namespace
}  // namespace wormdrag

namespace wormdrag {
namespace {

TEST(RecordingFacts, RelaxationTimeAndLinkSpeed) {
  EXPECT_DOUBLE_EQ(RelaxationTime({0, 0, 0.003, 0.002}, 0.1), kLinkMass / 0.002);
  EXPECT_DOUBLE_EQ(RelaxationTime({0.5, 0.2, 0, 0}, 0.1), kLinkMass / 2.0);  // μ_t / v = 2 µN·s/mm
  EXPECT_TRUE(std::isinf(RelaxationTime({0, 0, 0, 0}, 0.1)));
  // A straight body gliding at 0.3 mm/s: every link centre moves at 0.3 mm/s.
  Kinematics k;
  k.fps = 30;
  for (int f = 0; f < 10; ++f) {
    Frame fr;
    fr.t = f / k.fps;
    fr.valid = f != 4;
    fr.p = LabPoints({0.3 * fr.t, 0, 0}, Shape{}, 1.0 / kNumLinks);
    k.frames.push_back(fr);
  }
  EXPECT_NEAR(MedianLinkSpeed(k), 0.3, 1e-9);
}

// A free fit without tangential friction relaxes never: the note says so in words,
// never "inf".
TEST(RecordingFacts, ScaleBoundNoteSaysAnUnboundedTimeInWords) {
  const std::string finite = ScaleBoundNote(0.5, 1 / 300.0, 0.007, 0.017, 0.0033);
  EXPECT_NE(finite.find("was 0.5 s"), std::string::npos) << finite;
  EXPECT_NE(finite.find("now 0.0033 s"), std::string::npos) << finite;
  const double inf = RelaxationTime({0, 0, 0.01, 0}, 0.1);
  const std::string unbounded = ScaleBoundNote(inf, 1 / 300.0, 0.007, 0.017, inf);
  EXPECT_NE(unbounded.find("was unbounded (no tangential friction)"), std::string::npos) << unbounded;
  EXPECT_EQ(unbounded.find("inf"), std::string::npos) << unbounded;
  EXPECT_EQ(unbounded.find("nan"), std::string::npos) << unbounded;
}

TEST(Estimator, ScaleThatOutlastsAFrameIsBoundedAndRefitted) {
  // The truth is a physical scale; a frame interval of 1 s would need a relaxation time
  // of a second: the bound then pushes the fit's scale up, keeping the ratios.
  auto pair = Pair(kTruth);
  LocalEvaluator ev(pair, 2);
  EstimateOptions o;
  o.eval = ShortEval();
  o.search.n_max = 3;
  o.search.d_mu = 0.2;
  o.search.d_eta = 2e-3;
  o.search.d1 = 10;
  o.search.d2 = 5;
  RecordingFacts facts = FactsOf(*pair);
  facts.frame_interval = 0.1 * RelaxationTime(kTruth, facts.link_speed);  // the truth itself is too slow
  auto r = RunEstimate(ev, ev, o, pair->mean_body_length(), {}, facts);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_FALSE(r->scale_bound.empty());
  EXPECT_LE(RelaxationTime(r->best.set, facts.link_speed), 1.01 * facts.frame_interval);
  EXPECT_NEAR(r->best.set.K_mu(), kTruth.K_mu(), 0.02 * kTruth.K_mu());
  EXPECT_NE(r->ToText().find("refitted at fixed scale"), std::string::npos);
}

}  // namespace
}  // namespace wormdrag
