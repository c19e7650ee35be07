#!/usr/bin/env bash
# Real crawling worm → estimate → diagnose → report.
#
# The Schafer-lab Worm Tracker 2 recording of ../shared/data/real/modes2movement
# (30 fps, µm, plate coordinates; see PROVENANCE.md there). WT2 drops 5–8 frames
# every 12–25 frames while it re-centres its stage, and the recorded body moves
# ~1.7–2× as far across each burst as its speed predicts (the `gap_offset` artefact,
# docs/conventions.md §5). The only stretch without dropped frames is frames 398–498 (3.3 s).
# This walk-through fits its two halves as a pair (the paper pairs two recordings of
# one environment), continuous paths, no restarts: the comparison closest to the
# paper's 2 % of body length. docs/real-data.md has the other pairings.
# Output in $OUT (default build/examples/real-crawling).
source "$(dirname "$0")/common.sh"
OUT=${OUT:-$BUILD_DIR/examples/real-crawling}
MAT=$SHARED/data/real/modes2movement/short_worm_features.mat
need_shared "$MAT"
mkdir -p "$OUT"
DB=$OUT/jobs.db

# 1. Import (µm → mm, dropped frames kept as missing) and cut the two halves of the
#    gap-free run; time restarts at 0 in each file.
run "$WORMDRAG" import "$MAT" --out "$OUT/m2m.csv"
run "$WORMDRAG" import "$OUT/m2m.csv" --frames 398:447 --out "$OUT/H1.csv"
run "$WORMDRAG" import "$OUT/m2m.csv" --frames 448:498 --out "$OUT/H2.csv"

# 2. Estimate with the default options (GCV smoothing of the shapes, joints 3, 7, 10,
#    Phase 1 grid 11^4, Phase 2, Phase 3 GRG, 20 bootstrap refits for the intervals).
run "$WORMDRAG" estimate "$OUT/H1.csv" "$OUT/H2.csv" --t-max 1.6 --db "$DB" | tee "$OUT/estimate.txt"
ID=$(job_id "$OUT/estimate.txt")

# 3. Where the remaining error lies (wormdrag diagnose, docs/conventions.md §5), if this build has it.
#    SKIP_DIAGNOSE=1 skips it (it refits the pair once per catalogue effect).
#    1.6 s per worm keeps the walk-through short, so the diagnosis prints a caution
#    (record >= 5 s per worm; docs/diagnose.md analyses 8 s segments of this recording).
DIAG=()
if [[ ${SKIP_DIAGNOSE:-0} == 1 ]]; then
  echo "examples/real-crawling.sh: SKIP_DIAGNOSE=1: no diagnosis" >&2
elif "$WORMDRAG" diagnose --help > /dev/null 2>&1; then
  run "$WORMDRAG" diagnose "$OUT/H1.csv" "$OUT/H2.csv" --t-max 1.6 --json "$OUT/diagnosis.json" || true
  [[ -s $OUT/diagnosis.json ]] && DIAG=(--diagnosis "$OUT/diagnosis.json")
else
  echo "examples/real-crawling.sh: this wormdrag has no 'diagnose' command; the report has no diagnosis" >&2
fi

# 4. The report and the friction forces over time.
run "$REPORT" report "$ID" --db "$DB" --out "$OUT/report.html" "${DIAG[@]}"
run "$REPORT" analyze forces "$ID" --db "$DB" --csv "$OUT/forces.csv"
echo "examples/real-crawling.sh: open $OUT/report.html in a browser (works offline)" >&2
