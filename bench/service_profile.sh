#!/usr/bin/env bash
# Where a service job's time goes (BENCHMARKS.md, "Cost model"): the cost model's
# standard pair submitted with --bootstrap 0 to a coordinator and 2 local workers of one
# thread each, logging JSON; then per worker and per phase how long its tasks computed,
# how long it held them, and how long it waited between a report and its next lease.
# With a second build, alternates the two ROUNDS times; each round also runs embedded.
# Run it on an idle machine.
#
#   bench/service_profile.sh BUILD_DIR [OTHER_BUILD_DIR] [ROUNDS]   (outputs in BUILD_DIR/svcprof)
set -euo pipefail
here=$(realpath "$(dirname "$0")")
build=$(realpath "${1:-build}")
other=${2:+$(realpath "$2")}
rounds=${3:-2}
out=$build/svcprof
mkdir -p "$out"
wd=$build/client/wormdrag
coef=0.62,0.24,0.006,0.002
[ -f "$out/a.csv" ] || "$wd" generate --pattern 0.4,0 --coef $coef --duration 5 --fps 300 --out "$out/a.csv" >/dev/null 2>&1
[ -f "$out/b.csv" ] || "$wd" generate --pattern 0.6,0 --coef $coef --duration 5 --fps 300 --out "$out/b.csv" >/dev/null 2>&1

pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT

service() {  # service TAG BIN_DIR: one job on a fresh coordinator and 2 fresh workers
  local tag=$1 bin=$2 port=$((51000 + RANDOM % 1000))
  rm -f "$out/$tag".*
  "$bin/server/wormdrag-server" --listen 127.0.0.1:$port --db "$out/$tag.db" --log-json >"$out/$tag.server.log" 2>&1 &
  pids=($!)
  for _ in $(seq 100); do grep -q event=listening "$out/$tag.server.log" && break; sleep 0.1; done
  for i in 1 2; do
    "$bin/worker/wormdrag-worker" --server 127.0.0.1:$port --threads 1 --id w$i --log-json >"$out/$tag.w$i.log" 2>&1 &
    pids+=($!)
  done
  /usr/bin/time -f "%e" -o "$out/$tag.wall" "$wd" submit "$out/a.csv" "$out/b.csv" --server 127.0.0.1:$port \
    --bootstrap 0 --wait >"$out/$tag.submit.log" 2>&1
  kill "${pids[@]}" && wait "${pids[@]}" 2>/dev/null || true
  echo "== $tag ($bin): whole job $(cat "$out/$tag.wall") s wall"
  python3 "$here/service_profile.py" "$out/$tag"
}

for round in $(seq "$rounds"); do
  [ -n "$other" ] && service "other$round" "$other"
  service "this$round" "$build"
  rm -f "$out/embedded$round.db"
  /usr/bin/time -f "%e" -o "$out/embedded$round.wall" "$wd" estimate "$out/a.csv" "$out/b.csv" \
    --db "$out/embedded$round.db" --no-reuse --bootstrap 0 --threads 2 >"$out/embedded$round.log" 2>&1
  echo "== embedded$round: whole run $(cat "$out/embedded$round.wall") s wall"
done
