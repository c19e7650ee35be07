#!/usr/bin/env bash
# Real swimming worms → estimate, whole path and the paper's swimming protocol.
#
# CeleST swim-test centrelines in ../shared/data/real/celest (18.13 fps, a fixed
# camera; PROVENANCE.md there and docs/real-data.md §5). Worms 2 and 3 of Sample04
# are a pair of one environment whose heads the direction of travel names. These
# animals swim slowly (0.2–1 Hz) and turn, so the walk-through fits the pair twice:
# the whole 10 s path from one start, and the paper's protocol that restarts the
# simulated pose from the measured one every second (`--restart-every 1`). The
# result says whether each fit explains the motion (skill against a body that does
# not move) and which combinations the data determine (bootstrap intervals).
# Output in $OUT (default build/examples/real-swimming).
source "$(dirname "$0")/common.sh"
OUT=${OUT:-$BUILD_DIR/examples/real-swimming}
SEGM=$SHARED/data/real/celest/wormSegm_Sample04.txt
need_shared "$SEGM"
mkdir -p "$OUT"
DB=$OUT/jobs.db

# 1. Import one worm per file (calibration from fileDB.xml, head/tail by continuity
#    and direction of travel).
run "$WORMDRAG" import "$SEGM" --worm 2 --out "$OUT/S04_w2.csv"
run "$WORMDRAG" import "$SEGM" --worm 3 --out "$OUT/S04_w3.csv"

# 2. The whole path from one start (default options: GCV smoothing, 20 bootstrap refits).
run "$WORMDRAG" estimate "$OUT/S04_w2.csv" "$OUT/S04_w3.csv" --t-max 10 --db "$DB" | tee "$OUT/whole.txt"

# 3. The paper's swimming protocol: 1 s stretches, each from its measured start.
run "$WORMDRAG" estimate "$OUT/S04_w2.csv" "$OUT/S04_w3.csv" --t-max 10 --restart-every 1 --db "$DB" |
  tee "$OUT/restart1.txt"
ID=$(job_id "$OUT/restart1.txt")

# 4. Which part of the travel the fit reproduces: along the body (the propulsion the
#    friction law makes) and across it (a sideways drift no law makes; docs/real-data.md,
#    "What the swimming fits miss").
run "$WORMDRAG" analyze progress "$ID" --db "$DB" | tee "$OUT/progress.txt"
run "$REPORT" report "$ID" --db "$DB" --out "$OUT/report.html"
echo "examples/real-swimming.sh: open $OUT/report.html in a browser (works offline)" >&2
