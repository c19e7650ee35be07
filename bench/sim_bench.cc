// Simulator benchmarks. Reproduce: build/bench/sim_bench
#include <benchmark/benchmark.h>

#include "core/estimate/paired_path.h"
#include "core/estimate/search.h"
#include "core/sim/pattern.h"
#include "core/sim/simulator.h"

namespace wormdrag {
namespace {

const Coefficients kF{0.62, 0.21, 0.0071, 0.0013};

const Kinematics& Recording() {
  static const Kinematics k = [] {
    SimOptions sim;
    RecordingSpec spec;  // 300 fps, 5 s
    return *GenerateRecording(Locomotion(1), kF, sim, spec);
  }();
  return k;
}

// One 5 s simulation at 300 fps (13 links), one coefficient set.
void BM_SimulateOne(benchmark::State& state) {
  const Solver solver = state.range(0) ? Solver::kInertial : Solver::kQuasiStatic;
  BodyModel body;
  body.length = Recording().BodyLength();
  const ShapeDrive drive = *ShapeDrive::Build(Recording(), body, {static_cast<int>(state.range(1))});
  SimOptions opt;
  opt.solver = solver;
  SimWorkspace ws;
  Trajectory t;
  for (auto _ : state) {
    Simulator::SimulateBatch(drive, &kF, 1, opt, nullptr, ws, &t);
    benchmark::DoNotOptimize(t.poses.data());
  }
  state.SetLabel(std::string(SolverName(solver)) + ", substeps " + std::to_string(state.range(1)));
}
BENCHMARK(BM_SimulateOne)->ArgsProduct({{0, 1}, {1, 2}})->Unit(benchmark::kMillisecond);

// kLanes sets at once: time per set.
void BM_SimulateLanes(benchmark::State& state) {
  const Solver solver = state.range(0) ? Solver::kInertial : Solver::kQuasiStatic;
  BodyModel body;
  body.length = Recording().BodyLength();
  const ShapeDrive drive = *ShapeDrive::Build(Recording(), body, {static_cast<int>(state.range(1))});
  SimOptions opt;
  opt.solver = solver;
  SimWorkspace ws;
  Coefficients sets[kLanes];
  for (int i = 0; i < kLanes; ++i) sets[i] = {0.1 + 0.2 * i, 0.3, 0.002 * (i + 1), 0.004};
  Trajectory t[kLanes];
  for (auto _ : state) {
    Simulator::SimulateBatch(drive, sets, kLanes, opt, nullptr, ws, t);
    benchmark::DoNotOptimize(t[0].poses.data());
  }
  state.SetItemsProcessed(state.iterations() * kLanes);
  state.SetLabel(std::string(SolverName(solver)) + ", substeps " + std::to_string(state.range(1)));
}
BENCHMARK(BM_SimulateLanes)->ArgsProduct({{0, 1}, {1, 2}})->Unit(benchmark::kMillisecond);

// As BM_SimulateLanes (substeps 2), with the forward sensitivities to the four
// coefficients (Phase 3's exact Jacobian); arg 1: 1 set or kLanes sets.
void BM_SensitivityLanes(benchmark::State& state) {
  const Solver solver = state.range(0) ? Solver::kInertial : Solver::kQuasiStatic;
  const int count = state.range(1) ? kLanes : 1;
  BodyModel body;
  body.length = Recording().BodyLength();
  const ShapeDrive drive = *ShapeDrive::Build(Recording(), body, {2});
  SimOptions opt;
  opt.solver = solver;
  SimWorkspace ws;
  Coefficients sets[kLanes];
  for (int i = 0; i < kLanes; ++i) sets[i] = {0.1 + 0.2 * i, 0.3, 0.002 * (i + 1), 0.004};
  Trajectory t[kLanes];
  for (auto _ : state) {
    Simulator::SimulateBatchWithSensitivities(drive, sets, count, opt, nullptr, ws, t);
    benchmark::DoNotOptimize(t[0].sensitivities.data());
  }
  state.SetItemsProcessed(state.iterations() * count);
  state.SetLabel(std::string(SolverName(solver)) + ", " + std::to_string(count) + " sets");
}
BENCHMARK(BM_SensitivityLanes)->ArgsProduct({{0, 1}, {0, 1}})->Unit(benchmark::kMillisecond);

// A Phase-1-sized batch: the paper's 11^4 grid x 2 worms (Locomotion 1 + 2), 5 s at
// 300 fps each, at the screening step (one knot per frame), on 1 and on 2 threads.
void BM_Phase1Batch(benchmark::State& state) {
  static const std::shared_ptr<const PairedPath> pair = [] {
    SimOptions sim;
    RecordingSpec spec;
    const Coefficients c{0.62, 0.24, 0.006, 0.002};
    std::array<Kinematics, 2> k = {*GenerateRecording(Locomotion(1), c, sim, spec),
                                   *GenerateRecording(Locomotion(2), c, sim, spec)};
    EvaluationOptions e;
    e.knot_rate = 300;
    return *PairedPath::Create(k, {"L1", "L2"}, e);
  }();
  const auto sets = GridSets(SearchOptions());
  LocalEvaluator ev(pair, static_cast<int>(state.range(0)));
  std::vector<double> e;
  for (auto _ : state) {
    (void)ev.Evaluate(sets, &e);
    benchmark::DoNotOptimize(e.data());
  }
  state.counters["sets"] = static_cast<double>(sets.size());
  state.counters["simulations/s"] = benchmark::Counter(2.0 * sets.size() * state.iterations(),
                                                       benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Phase1Batch)->Arg(1)->Arg(2)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace
}  // namespace wormdrag

BENCHMARK_MAIN();
