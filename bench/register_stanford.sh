#!/bin/bash
# The 6 directed Stanford pairs (bun000, bun045, the zipper reconstruction) with default
# settings, errors against bun.conf (+ the zipper at identity). usage:
#   bench/register_stanford.sh BUILD_DIR [DATA_DIR]   (DATA_DIR default ../shared/data/pointclouds/stanford_bunny)
set -euo pipefail
build=${1:?usage: register_stanford.sh BUILD_DIR [DATA_DIR]}
data=${2:-$(dirname "$0")/../../shared/data/pointclouds/stanford_bunny}
conf=$(mktemp)
trap 'rm -f "$conf"' EXIT
cat "$data/bun.conf" > "$conf"
echo "bmesh bun_zipper_res2.ply 0 0 0 0 0 0 1" >> "$conf"
for pair in "bun045 bun000" "bun000 bun045" "bun000 bun_zipper_res2" "bun045 bun_zipper_res2" \
            "bun_zipper_res2 bun000" "bun_zipper_res2 bun045"; do
  set -- $pair
  echo "== $1 -> $2"
  nice -n 10 "$build/bench/register_pair" "$data/$1.ply" "$data/$2.ply" auto conf="$conf" 2>&1 |
    grep -E "^points|resolution|sigma RMS|error vs|^wall" || true
done
