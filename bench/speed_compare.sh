#!/usr/bin/env bash
# Two builds side by side on the cost model's standard pair and on Phase 3 alone
# (BENCHMARKS.md, "Small batches split by worm"): the whole pipeline (--bootstrap 0,
# 2 threads), Phase 3 from the example pair's Phase 2 survivors, and bootstrap refits 0
# and 3 on 2 threads, alternating the builds ROUNDS times. Run it on an idle machine.
#
#   bench/speed_compare.sh OLD_BUILD_DIR NEW_BUILD_DIR [ROUNDS]
#
# e.g. git worktree add --detach ../base c2ef17e, build it, then
#   bench/speed_compare.sh ../base/build build 2
set -euo pipefail
cd "$(dirname "$0")/.."
old=$1 new=$2 rounds=${3:-2}
out=${new}/speed_compare
mkdir -p "$out"
coef=0.62,0.24,0.006,0.002
[ -f "$out/a.csv" ] || "$new/client/wormdrag" generate --pattern 0.4,0 --coef $coef --duration 5 --fps 300 --out "$out/a.csv" >/dev/null 2>&1
[ -f "$out/b.csv" ] || "$new/client/wormdrag" generate --pattern 0.6,0 --coef $coef --duration 5 --fps 300 --out "$out/b.csv" >/dev/null 2>&1
starts='0.5,0.2,0.0105,0.0;0.5,0.2,0.01,0.0;0.5,0.2,0.0095,0.0;0.5,0.2,0.009000000000000001,0.0;0.5,0.2,0.0085,0.0;0.5,0.2,0.008,0.0;0.5,0.2,0.0075,0.0;0.5,0.2,0.0105,0.0005;0.5,0.2,0.007,0.0;0.5,0.2,0.01,0.0005;0.5,0.2,0.006500000000000001,0.0'
estimate=0.6062136307,0.2346992501,0.006193702259,0.001926448903
timed() { /usr/bin/time -f "wall %e s, CPU %U s" "$@" 2>&1; }
for round in $(seq "$rounds"); do
  for which in old new; do
    b=$old
    [ $which = new ] && b=$new
    rm -f "$out/e.db"
    phases=$(timed "$b/client/wormdrag" estimate "$out/a.csv" "$out/b.csv" --db "$out/e.db" --no-reuse --bootstrap 0 \
      --threads 2 --t-max 5 --n-max 10 | awk '$1 ~ /^phase[123]$/ && $3 == "sets" {printf "%s %s s, ", $1, $4}
        $1 == "phase3" && $2 ~ /^\(/ {printf "phase3 %s s, ", $5} /^wall/ {print}')
    echo "round $round $which pipeline: $phases"
    echo "round $round $which phase 3: $(timed "$b/bench/phase3_bench" examples/data/L1.csv examples/data/L2.csv \
      --threads 2 --jacobian exact --start "$starts" | tail -2 | tr '\n' ' ')"
    for r in 0 3; do
      echo "round $round $which refit $r: $(timed "$b/bench/phase3_bench" examples/data/L1.csv examples/data/L2.csv \
        --start $estimate --replicate $r --threads 2 --smoothing auto --jacobian exact | tail -2 | tr '\n' ' ')"
    done
  done
done
