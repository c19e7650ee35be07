#!/usr/bin/env bash
# Coordinator capacity (BENCHMARKS.md, "Coordinator capacity"): for each row a fresh
# coordinator with a status page, service_bench's fake workers against it, and the
# SQLite writer's busy share from /metrics (each row twice); then Phase 1 per core (14 641 sets) of a real estimate on
# 2-s/100-fps and paper-length (5-s/300-fps) recordings. Prints markdown tables.
#
#   bench/capacity.sh [BUILD_DIR]      (default build; outputs go to BUILD_DIR/capacity)
set -euo pipefail
build=$(realpath "${1:-build}")
out=$build/capacity
rm -rf "$out" && mkdir -p "$out"
wd=$build/client/wormdrag
server=$build/server/wormdrag-server
bench=$build/server/service_bench
port=50700
http=51000

"$wd" generate --pattern 0.4,0 --coef 0.5,0.2,0.005,0.002 --fps 100 --duration 2 --out "$out/b1.csv" >/dev/null
"$wd" generate --pattern 0.6,0 --coef 0.5,0.2,0.005,0.002 --fps 100 --duration 2 --out "$out/b2.csv" >/dev/null
"$wd" generate --pattern 0.4,0 --coef 0.5,0.2,0.005,0.002 --fps 300 --duration 5 --out "$out/p1.csv" >/dev/null
"$wd" generate --pattern 0.6,0 --coef 0.5,0.2,0.005,0.002 --fps 300 --duration 5 --out "$out/p2.csv" >/dev/null

metric() { curl -s "http://127.0.0.1:$http/metrics" | awk -v m="$1" '$1 == m { print $2 }'; }

# row FLAGS WORKERS JOBS
row() {
  local flags=$1 workers=$2 jobs=$3 n=$((row_count++))
  port=$((port + 1)) http=$((http + 1))
  # shellcheck disable=SC2086
  "$server" --listen 127.0.0.1:$port --db "$out/cap$n.db" --http $http $flags >"$out/server$n.log" 2>&1 &
  local pid=$!
  for _ in $(seq 100); do curl -s "http://127.0.0.1:$http/metrics" >/dev/null && break; sleep 0.1; done
  local line
  line=$("$bench" --server 127.0.0.1:$port --workers "$workers" --jobs "$jobs" --n-max 10 --recording "$out/b1.csv")
  local sum count
  sum=$(metric wormdrag_sqlite_commit_seconds_sum)
  count=$(metric wormdrag_sqlite_commit_seconds_count)
  kill "$pid" && wait "$pid" || true
  # "workers W, jobs J, Phase 1 S sets in T s: L leases/s (= reports/s), R sets ingested/s"
  echo "$line" | awk -v f="${flags:-defaults}" -v s="$sum" -v c="$count" '{
    t = $10; printf "| %s | %d | %d | %s | %s | %.0f %% | %.1f ms |\n", f, $2, $4, $12, $16, 100 * s / t, 1000 * s / c }'
}

echo "| server flags | fake workers | jobs | reports/s | sets ingested/s | writer busy | mean commit |"
echo "|---|---|---|---|---|---|---|"
row_count=0
for w in 8 32 64; do
  for j in 1 4; do row "" $w $j; row "" $w $j; done
done
row "--parallelism 128" 64 4
row "--parallelism 128" 64 4
for j in 1 4; do row "--chunk-sets 8 --parallelism 512" 32 $j; row "--chunk-sets 8 --parallelism 512" 32 $j; done

echo
echo "| recordings | Phase 1 sets/s, full grid | Phase 1 sets/s, early abandoning |"
echo "|---|---|---|"
for rec in b p; do
  rates=()
  tmax=$([ $rec = b ] && echo 2 || echo 5)
  for mode in --full-grid ""; do
    # shellcheck disable=SC2086
    log=$("$wd" estimate "$out/${rec}1.csv" "$out/${rec}2.csv" --db "$out/pc-$rec$mode.db" --threads 1 \
      --n-max 10 --t-max $tmax --phase3 none --bootstrap 0 --smoothing none --no-reuse $mode 2>&1)
    # the summary line "  phase1   2401 sets   3.7 s  best E ..."
    rates+=("$(echo "$log" | awk '$1 == "phase1" && $3 == "sets" { printf "%.0f", $2 / $4 }')")
  done
  label=$([ $rec = b ] && echo "2 s at 100 fps" || echo "5 s at 300 fps (paper length)")
  echo "| $label | ${rates[0]} | ${rates[1]} |"
done
