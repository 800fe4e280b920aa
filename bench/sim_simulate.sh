#!/usr/bin/env bash
# Bench: wall time and peak memory of `mmba simulate` for a scene and preset.
#   bench/sim_simulate.sh MMBA_BINARY SCENE PRESET OUT_DIR     e.g. build/apps/mmba gate small /tmp/simgate
set -euo pipefail
mmba=${1:?mmba binary}
scene=${2:-gate}
preset=${3:-small}
out=${4:?output folder}
rm -rf "$out"
/usr/bin/time -v "$mmba" simulate --scene "$scene" --preset "$preset" --out "$out" --threads "${THREADS:-2}" \
  2> "$out.time.log"
grep -E "simulate:|Elapsed \(wall|Maximum resident" "$out.time.log"
du -sh "$out"
