#!/usr/bin/env bash
# SunRay III benchmarks on the compose clusters; writes deploy/bench/results/report.md and
# PNG plots. Takes the machine's cores for several minutes: run it on a quiet machine.
#
#   deploy/bench/run.sh                  # scaling, hetero, fault
#   deploy/bench/run.sh scaling          # one of them (the others' results are kept)
#   deploy/bench/run.sh bigscene         # 1M and 4M triangles, first and cached submit
#   deploy/bench/run.sh chaos            # eight jobs of three users through 30 faults
#   deploy/bench/run.sh upgrade          # every remd replaced, one at a time, mid-job
#   deploy/bench/run.sh shares           # three users' jobs sharing the farm's slots
#
# BENCH_RES (default 512x512) and BENCH_SAMPLES set the render; SKIP_IMAGE=1 uses the
# image as it is; SUNRAY_SCENES is the folder holding mount6.nff (default: one generated
# with `sunray spd mount`, which writes Haines's file byte for byte).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
cd "$root"
if [ -z "${SKIP_IMAGE:-}" ]; then deploy/build-image.sh; fi
mkdir -p "$here/work" && chmod 1777 "$here/work"      # images are written by the daemons' user
REM_CREDENTIALS="$here/work/credentials" deploy/credentials.sh >/dev/null
if [ -z "${SUNRAY_SCENES:-}" ]; then
  SUNRAY_SCENES="$here/work/scenes"; mkdir -p "$SUNRAY_SCENES"
  "${CARGO_TARGET_DIR:-target}/release/sunray" spd mount -o "$SUNRAY_SCENES/mount6.nff"
fi
export SUNRAY_SCENES
python3 -c 'import matplotlib' 2>/dev/null || pip install -q matplotlib || true
python3 "$here/bench.py" "$@"
python3 "$here/report.py"
