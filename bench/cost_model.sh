#!/usr/bin/env bash
# How an estimate's time grows with the recording and the grid (BENCHMARKS.md, "Cost
# model"): the paper's Locomotion 1+2 pair (friction 0.62, 0.24, 0.006, 0.002; patterns
# 0.4 and 0.6 rad) generated at each length and frame rate, estimated embedded with
# default options but no intervals (--bootstrap 0), one setting varied at a time around
# 5 s, 300 fps, N_max 10; then the standard pair with 1 and 2 local workers of one thread
# each; then a perf profile of the standard run. Prints markdown tables.
#
#   bench/cost_model.sh [BUILD_DIR]      (default build; outputs go to BUILD_DIR/cost)
set -euo pipefail
build=$(realpath "${1:-build}")
out=$build/cost
rm -rf "$out" && mkdir -p "$out"
wd=$build/client/wormdrag
coef=0.62,0.24,0.006,0.002

pair() {  # pair DURATION FPS -> writes $out/a-D-F.csv, $out/b-D-F.csv
  "$wd" generate --pattern 0.4,0 --coef $coef --duration "$1" --fps "$2" --out "$out/a-$1-$2.csv" 2>/dev/null
  "$wd" generate --pattern 0.6,0 --coef $coef --duration "$1" --fps "$2" --out "$out/b-$1-$2.csv" 2>/dev/null
}

# Seconds of each phase from the result's summary lines ("  phase1  14641 sets  3.9 s ...").
phases() { awk '$1 ~ /^phase[123]$/ && $3 == "sets" { printf "%s %s ", $2, $4 } $1 == "phase3" && $2 ~ /^\(/ { printf "%s %s ", $3, $5 }'; }

row() {  # row DURATION FPS NMAX
  local d=$1 f=$2 n=$3 log times
  [ -f "$out/a-$d-$f.csv" ] || pair "$d" "$f"
  local TIMEFORMAT="%R %U %S"
  { time "$wd" estimate "$out/a-$d-$f.csv" "$out/b-$d-$f.csv" --db "$out/e-$d-$f-$n.db" --no-reuse --bootstrap 0 \
    --threads 2 --t-max "$d" --n-max "$n" >"$out/e-$d-$f-$n.log" 2>&1; } 2>"$out/e-$d-$f-$n.time"
  log=$(cat "$out/e-$d-$f-$n.log")
  times=($(cat "$out/e-$d-$f-$n.time"))
  # shellcheck disable=SC2046
  set -- $(echo "$log" | phases)
  printf "| %s s | %s | %s | %s (%s) | %s (%s) | %s (%s) | %.1f | %.1f |\n" "$d" "$f" "$n" "$2" "$1" "$4" "$3" "$6" "$5" \
    "${times[0]}" "$(echo "${times[1]} + ${times[2]}" | bc)"
}

echo "| length | fps | N_max | Phase 1 s (sets) | Phase 2 s (sets) | Phase 3 s (sets) | whole run, wall s | CPU s |"
echo "|---|---|---|---|---|---|---|---|"
row 5 300 10
for d in 1 20; do row $d 300 10; done
for f in 30 100; do row 5 $f 10; done
for n in 5 15; do row 5 300 $n; done

echo
echo "| standard pair (5 s, 300 fps, N_max 10) | whole job, wall s |"
echo "|---|---|"
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT
for workers in 1 2; do
  port=$((50800 + workers))
  "$build/server/wormdrag-server" --listen 127.0.0.1:$port --db "$out/srv$workers.db" >"$out/srv$workers.log" 2>&1 &
  pids=($!)
  for _ in $(seq $workers); do
    "$build/worker/wormdrag-worker" --server 127.0.0.1:$port --threads 1 >>"$out/workers$workers.log" 2>&1 &
    pids+=($!)
  done
  for _ in $(seq 100); do grep -q event=listening "$out/srv$workers.log" && break; sleep 0.1; done
  t0=$(date +%s.%N)
  "$wd" submit "$out/a-5-300.csv" "$out/b-5-300.csv" --server 127.0.0.1:$port --bootstrap 0 --wait \
    >"$out/submit$workers.log" 2>&1
  t1=$(date +%s.%N)
  kill "${pids[@]}" 2>/dev/null || true
  wait "${pids[@]}" 2>/dev/null || true
  printf "| coordinator + %d worker(s) of 1 thread | %.1f |\n" "$workers" "$(echo "$t1 - $t0" | bc)"
done

if command -v perf >/dev/null; then
  echo
  echo "Profile of the standard run (perf, self time, top symbols):"
  echo
  perf record -q -g -o "$out/perf.data" -- "$wd" estimate "$out/a-5-300.csv" "$out/b-5-300.csv" \
    --db "$out/perf.db" --no-reuse --bootstrap 0 --threads 2 >/dev/null 2>&1 || true
  perf report -i "$out/perf.data" --no-children --stdio --percent-limit 2 2>/dev/null |
    awk '/^ +[0-9.]+%/ { sub(/\[\.\] /, ""); print "    " $0 }' | head -20
fi
