#!/usr/bin/env bash
# The diagnosis of the real crawling recording (docs/diagnose.md "Real data"): frames
# 0-249 and 250-498 of the Worm Tracker 2 features file as two recordings (time re-zeroed
# at each), diagnosed with the default thresholds. Writes diagnosis.{txt,json} and
# report.html to build/diagnose_modes2movement/ (or $OUT). Needs a built tree
# (scripts/dev.sh build).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${WORMDRAG:-$root/build/client/wormdrag}"
mat="$root/../shared/data/real/modes2movement/short_worm_features.mat"
out="${OUT:-$root/build/diagnose_modes2movement}"
mkdir -p "$out"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$bin" import "$mat" --frames 0:249 --out "$tmp/seg1.csv"
"$bin" import "$mat" --frames 250:498 --out "$tmp/seg2.csv"
/usr/bin/time -f "%e s wall, %U s user" "$bin" diagnose "$tmp/seg1.csv" "$tmp/seg2.csv" --t-max 8 --interpolate-gaps 8 \
    --blocks 4 --threads "${THREADS:-1}" \
    --json "$out/diagnosis.json" --report "$out/report.html" | tee "$out/diagnosis.txt"
