#!/usr/bin/env bash
# Synthetic pair → estimate → report → §4 analyses.
#
# The bundled pair examples/data/L1.csv, L2.csv was simulated with the paper's
# Locomotion 1 and 2 joint-angle patterns and the coefficients in their
# '# coefficients:' line (0.62, 0.24, 0.006, 0.002), so the estimate can be checked
# against the truth. Output in $OUT (default build/examples/synthetic).
source "$(dirname "$0")/common.sh"
OUT=${OUT:-$BUILD_DIR/examples/synthetic}
mkdir -p "$OUT"
DB=$OUT/jobs.db

# 1. Estimate (Phase 1 grid of 11^4 sets, Phase 2, Phase 3 GRG, identifiability) over
#    the first 2 s of both recordings; stored in $DB. A second run reuses the result.
run "$WORMDRAG" estimate examples/data/L1.csv examples/data/L2.csv --t-max 2 --db "$DB" | tee "$OUT/estimate.txt"
ID=$(job_id "$OUT/estimate.txt")
grep '^# coefficients' examples/data/L1.csv

# 2. The report: one self-contained HTML file.
run "$REPORT" report "$ID" --db "$DB" --out "$OUT/report.html"

# 3. The paper's §4 analyses: forces per link (Fig. 12) and the paths of other
#    coefficient sets for the same joint angles (Fig. 11, 13): the truth, the truth
#    ×3 (same ratios: the same path up to inertia) and a set with another K_mu.
run "$REPORT" analyze forces "$ID" --db "$DB" --csv "$OUT/forces.csv"
run "$REPORT" analyze trajectories "$ID" --db "$DB" \
  --coef 0.62,0.24,0.006,0.002 --coef 1.86,0.72,0.018,0.006 --coef 0.31,0.24,0.006,0.002

echo "examples/synthetic.sh: open $OUT/report.html in a browser (works offline)" >&2
