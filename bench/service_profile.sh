#!/usr/bin/env bash
# Where a service job's time goes (BENCHMARKS.md, "Cost model"): the cost model's
# standard pair submitted (no intervals unless BOOTSTRAP) to a coordinator and local
# workers of one thread each, logging JSON; then per worker and phase how long its tasks computed,
# how long it held them, and how long it waited between a report and its next lease.
# With a second build, alternates the two ROUNDS times; each round also runs embedded.
# BOOTSTRAP=N (default 0) asks for N bootstrap refits; WORKERS="1 2" (default 2) runs
# one job per worker count, to see the refits spread over workers. Run it on an idle
# machine.
#
#   bench/service_profile.sh BUILD_DIR [OTHER_BUILD_DIR] [ROUNDS]   (outputs in BUILD_DIR/svcprof)
set -euo pipefail
here=$(realpath "$(dirname "$0")")
build=$(realpath "${1:-build}")
other=${2:+$(realpath "$2")}
rounds=${3:-2}
bootstrap=${BOOTSTRAP:-0}
out=$build/svcprof
mkdir -p "$out"
wd=$build/client/wormdrag
coef=0.62,0.24,0.006,0.002
[ -f "$out/a.csv" ] || "$wd" generate --pattern 0.4,0 --coef $coef --duration 5 --fps 300 --out "$out/a.csv" >/dev/null 2>&1
[ -f "$out/b.csv" ] || "$wd" generate --pattern 0.6,0 --coef $coef --duration 5 --fps 300 --out "$out/b.csv" >/dev/null 2>&1

pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT

service() {  # service TAG BIN_DIR WORKERS: one job on a fresh coordinator and fresh workers
  local tag=$1 bin=$2 workers=$3 port=$((51000 + RANDOM % 1000))
  rm -f "$out/$tag".*
  "$bin/server/wormdrag-server" --listen 127.0.0.1:$port --db "$out/$tag.db" --log-json >"$out/$tag.server.log" 2>&1 &
  pids=($!)
  for _ in $(seq 100); do grep -q event=listening "$out/$tag.server.log" && break; sleep 0.1; done
  for i in $(seq "$workers"); do
    "$bin/worker/wormdrag-worker" --server 127.0.0.1:$port --threads 1 --id w$i --log-json >"$out/$tag.w$i.log" 2>&1 &
    pids+=($!)
  done
  /usr/bin/time -f "%e" -o "$out/$tag.wall" "$wd" submit "$out/a.csv" "$out/b.csv" --server 127.0.0.1:$port \
    --bootstrap "$bootstrap" --wait >"$out/$tag.submit.log" 2>&1
  kill "${pids[@]}" && wait "${pids[@]}" 2>/dev/null || true
  echo "== $tag ($bin, $workers workers): whole job $(cat "$out/$tag.wall") s wall"
  python3 "$here/service_profile.py" "$out/$tag"
}

for round in $(seq "$rounds"); do
  for w in ${WORKERS:-2}; do
    [ -n "$other" ] && service "other$round-w$w" "$other" "$w"
    service "this$round-w$w" "$build" "$w"
  done
  rm -f "$out/embedded$round.db"
  /usr/bin/time -f "%e" -o "$out/embedded$round.wall" "$wd" estimate "$out/a.csv" "$out/b.csv" \
    --db "$out/embedded$round.db" --no-reuse --bootstrap "$bootstrap" --threads 2 >"$out/embedded$round.log" 2>&1
  echo "== embedded$round: whole run $(cat "$out/embedded$round.wall") s wall"
done
