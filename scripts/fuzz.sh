#!/usr/bin/env bash
# Fuzzing: builds the libFuzzer targets of tests/fuzz with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer (WORMDRAG_FUZZ=ON) in a build directory of their own, runs
# each target for a bounded time on its seed corpus, then, once, the unit tests of core/
# and the fuzz regressions under the same sanitizers (but for a few tests too slow under
# ASan: the slow=(...) list below; docs/reliability.md, "Unit tests under the sanitizers").
# About 24 min for 60 s per target on a 2-core machine with an empty ccache, 14 min with a
# warm one. Exits non-zero on any finding; the input that caused it is left in
# $FUZZ_WORK/<target>/ (keep it in tests/fuzz/regressions/<target>/ once fixed).
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET [TARGET...]]   (default 60 s, every target)
#
# Environment: FUZZ_BUILD_DIR (default build-fuzz), FUZZ_WORK (default
# $FUZZ_BUILD_DIR/work: the grown corpora), JOBS (default: number of cores).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build_dir=${FUZZ_BUILD_DIR:-build-fuzz}
work=${FUZZ_WORK:-$build_dir/work}
jobs=${JOBS:-$(nproc)}
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(kinematics_csv wcon npy wt2_mat celest job_options)

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DWORMDRAG_FUZZ=ON "${launcher[@]}" >/dev/null
# Everything this configuration holds: core/, the fuzz targets, the unit tests of core/
# and the fuzz regressions (ctest needs every test binary it discovers).
build_start=$SECONDS
cmake --build "$build_dir" -j "$jobs"
echo "fuzz.sh: build took $((SECONDS - build_start)) s" >&2

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# Leaks inside third-party libraries we cannot fix, each with its reason and finding.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/tests/fuzz/lsan.supp:print_suppressions=0}
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$work/$t/corpus"
  log="$work/$t/log.txt"
  echo "fuzz.sh: $t for ${seconds} s" >&2
  extra=()
  asan=$ASAN_OPTIONS
  # matio allocates what a damaged .mat header claims (gigabytes) before anything can
  # check it, and fails cleanly when the allocation does; untouched, such memory costs
  # nothing outside ASan (regressions/wt2_mat/huge_claimed_size.mat runs in 12 MB). For
  # this target an allocation over 256 MB fails, as on a machine without the memory,
  # instead of being a finding (ASan would zero and quarantine gigabytes per input).
  if [ "$t" = wt2_mat ]; then
    extra=(-malloc_limit_mb=1048576)
    asan="$asan:allocator_may_return_null=1:max_allocation_size_mb=256"
  fi
  if ASAN_OPTIONS="$asan" \
     "$build_dir/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 "${extra[@]}" \
       -print_final_stats=1 -artifact_prefix="$work/$t/" "$work/$t/corpus" "tests/fuzz/corpus/$t" >"$log" 2>&1; then
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    echo "fuzz.sh: $t: ${execs:-?} executions, no finding" >&2
  else
    echo "fuzz.sh: $t: FINDING (see $log and $work/$t/crash-* / leak-* / timeout-*)" >&2
    tail -40 "$log" >&2
    failed+=("$t")
  fi
done

# The unit tests of core/ and the fuzz regressions, once, under the same sanitizers. Left
# out: the tests that take over 90 s each under ASan on this 2-core machine (~20-30x
# their time in the normal build, where they all run); the code they exercise also runs
# here in the faster tests named in each comment. docs/reliability.md lists their times.
slow=(
  # Whole estimations (grid, refinement, phase 3), 100-235 s each; the estimator's path
  # stays covered by JobsTest.RunsRecordsAndReuses and the Grg/Search/EvaluateLanes tests.
  '^Estimator\.(RecoversIdentifiableCombinations|EarlyAbandoningKeepsTheSurvivorsBitForBit)$'
  '^Estimator\.ScaleThatOutlastsAFrameIsBoundedAndRefitted$'
  '^Phase3\.ExactJacobiansReachTheSameOptimumWithFewerSets$'
  # Finite differences of whole simulations for every coefficient, 150 s; the other
  # Sensitivity and ResidualJacobian tests stay.
  '^Sensitivity\.AgreesWithFiniteDifferences$'
  # Many diagnosis fits from many starts, 245 s; the other Diagnose tests stay.
  '^Diagnose\.FitsThatNeverLeaveTheirStartLeaveTheParameterUnestimated$'
  # Estimation jobs run two or more times over or on a full grid, 115-265 s;
  # JobsTest.RunsRecordsAndReuses (a whole job, then its reuse) and the RunBootstrap,
  # DiagnoseJobJson and HostileJobTest tests stay.
  '^JobsTest\.(ResultCarriesSmoothingStillBodyAndIntervals|InterruptedJobResumesFromStoredEvaluations)$'
  '^JobsTest\.(EvaluationsOfFailedOrCancelledJobsAreNeverReused|FullGridStoresEveryEAndTheSameSurvivors)$'
)
exclude=$(IFS='|'; echo "${slow[*]}")
echo "fuzz.sh: unit tests of core/ and fuzz regressions under ASan+UBSan (${#slow[@]} slow patterns left out)" >&2
tests_start=$SECONDS
ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --timeout 900 -E "$exclude"
echo "fuzz.sh: tests took $((SECONDS - tests_start)) s" >&2

if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: findings in ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: ${#targets[@]} targets, no finding" >&2
