#!/usr/bin/env bash
# Issue 31's GPU targets on a GPU machine staged by ../shared/gpu/README.md (mujoco, warp-lang and mujoco-warp
# unpacked under /tmp/site): each printed as PASS or FAIL with its number, and kept under $OUT (check.txt,
# check.json, one file per command's output). This checkout's own code runs (a shim in front of /tmp/site).
#
# usage, from the repository root:   OUT=/some/dir examples/gpu/check.sh [STEP ...] [--dry-run]
#   STEP: env warmup one_world compare bench worlds map tune (all, in this order, by default)
#   --dry-run: every step on warp's CPU device with small sizes (what runs here, checked without a GPU)
# exit: 0 all PASS, 1 some FAIL, 2 a bad step name
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
export OUT=${OUT:-/tmp/chatterbench-gpu-check}
mkdir -p "$OUT"
shim=$(mktemp -d)
mkdir -p "$shim/chatterbench"
for d in comparisons engines reference; do ln -s "$root/$d" "$shim/chatterbench/$d"; done
export PYTHONPATH="$shim:${SITE:-/tmp/site}${PYTHONPATH:+:$PYTHONPATH}"
cd "$root"
python3 "$root/examples/gpu/check.py" "$@" 2>&1 | tee -a "$OUT/check.log"
code=${PIPESTATUS[0]}
rm -rf "$shim"
exit "$code"
