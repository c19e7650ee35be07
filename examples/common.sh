# Shared by the example scripts: where the build and the wormdrag binary are.
# BUILD_DIR (default build, as scripts/dev.sh), WORMDRAG (default $BUILD_DIR/client/wormdrag).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
BUILD_DIR=${BUILD_DIR:-build}
WORMDRAG=${WORMDRAG:-$BUILD_DIR/client/wormdrag}
if [[ ! -x $WORMDRAG ]]; then
  echo "examples: $WORMDRAG not found; run scripts/dev.sh build first (or set WORMDRAG)" >&2
  exit 2
fi
REPORT=$WORMDRAG
# Runs a command, echoing it first (so the walk-through reads as a transcript).
run() {
  echo "+ $*" >&2
  "$@"
}
# The job id from the first line ("job N") of wormdrag estimate's text output.
job_id() { sed -n 's/^job \([0-9][0-9]*\)$/\1/p' "$1" | head -n 1; }
# The folder holding data/real (SHARED, default ../shared), and a check that a file of it is there.
SHARED=${SHARED:-../shared}
need_shared() {
  if [[ ! -f $1 ]]; then
    echo "$(basename "$0"): $1 not found (set SHARED to the folder holding data/real)" >&2
    exit 2
  fi
}
