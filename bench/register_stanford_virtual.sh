#!/bin/bash
# The Stanford bunny's pairwise registrations beyond the two real scans in the data: virtual
# scans of every bun.conf view (bench/stanford_virtual_scans.py) registered with the default
# settings, mmba (bench/register_pair: whole registration, error against bun.conf) and Open3D's
# textbook FPFH + RANSAC + point-to-plane ICP (bench/register_open3d.py, voxel 2 mm). usage:
#   bench/register_stanford_virtual.sh BUILD_DIR SCANS_DIR [PAIRS...]
# SCANS_DIR is written by `stanford_virtual_scans.py SCANS_DIR` (bun000/bun045 are the real
# scans); PAIRS default to the adjacent views and the top/chin/ear views against their
# best-overlapping neighbour, "SOURCE:TARGET".
set -euo pipefail
build=${1:?usage: register_stanford_virtual.sh BUILD_DIR SCANS_DIR [PAIRS...]}
scans=${2:?usage: register_stanford_virtual.sh BUILD_DIR SCANS_DIR [PAIRS...]}
shift 2
pairs=("$@")
if [ ${#pairs[@]} -eq 0 ]; then
  pairs=(bun045:bun000 bun090:bun045 bun180:bun090 bun270:bun180 bun315:bun270 bun315:bun000
         bun090:bun000 top2:bun180 top3:bun090 chin:bun315 ear_back:bun180 top3:bun000 chin:bun000)
fi
here=$(dirname "$0")
for pair in "${pairs[@]}"; do
  s=${pair%%:*}; t=${pair##*:}
  echo "== $s -> $t"
  /usr/bin/time -f "mmba whole process: %e s wall, %U+%S s CPU, %M KiB" \
    nice -n 10 "$build/bench/register_pair" "$scans/$s.ply" "$scans/$t.ply" auto \
    conf="$scans/bun.conf" 2>&1 | grep -E "error vs|^points|mmba whole" | sed -E "s/^points.*registration (ok|failed|[a-z]+)[:,]? ?(descriptor [a-z0-9]+)?.*/mmba: \1 \2/" || true
  /usr/bin/time -f "open3d whole process: %e s wall, %U+%S s CPU, %M KiB" \
    nice -n 10 /usr/bin/python3 "$here/register_open3d.py" "$scans/$s.ply" "$scans/$t.ply" 0.002 \
    --conf "$scans/bun.conf" 2>&1 | grep -E "error vs|open3d whole" || true
done
