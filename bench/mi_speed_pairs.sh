#!/usr/bin/env bash
# MI registration speed of two builds of a change (a reference build and the changed one): each
# bench run by both builds at the same time, one thread each, so that both see the same load on
# a shared machine; compares the process CPU (user + sys) and peak RSS of /usr/bin/time -v, and
# the result digests (equal = the change did not alter any result). bench/RESULTS.md, "Speed
# of two builds".
#   [AFTER_ENV="VAR=value ..."] bench/mi_speed_pairs.sh BEFORE_BENCH_DIR AFTER_BENCH_DIR OUT_DIR [KITTI_DIR=data/kitti]
# AFTER_ENV: extra environment for the changed build only (e.g. MI_ALL_CHECKS=1: the changed
# build measuring every check after a failed one too, so that the digests must be equal).
# e.g. BEFORE = a Release build of the reference commit (git archive OLD | tar -x -C SRC; cmake SRC
# -DCMAKE_BUILD_TYPE=Release; make mi_speed mi_kitti), AFTER = build-mi/bench.
set -euo pipefail
B=$1; N=$2; O=$3; KITTI=${4:-data/kitti}
mkdir -p "$O"
run_pair() {  # name, environment, bench and its arguments
  local name=$1 envs=$2; shift 2
  env MI_THREADS=1 $envs /usr/bin/time -v "$B/$1" "${@:2}" > "$O/before_$name.txt" 2>&1 &
  env MI_THREADS=1 $envs ${AFTER_ENV:-} /usr/bin/time -v "$N/$1" "${@:2}" > "$O/after_$name.txt" 2>&1 &
  wait
}
for m in 1 8; do
  for r in intensity points depth; do run_pair "speed_${m}_${r}" "MI_POINT_SAMPLES=0" mi_speed $m $r; done
  run_pair "speed_${m}_intensity_ps" "MI_POINT_SAMPLES=1" mi_speed $m intensity
done
run_pair speed_1_points_ps "MI_POINT_SAMPLES=1" mi_speed 1 points
run_pair speed_1_depth_ps "MI_POINT_SAMPLES=1" mi_speed 1 depth
run_pair kitti "MI_POINT_SAMPLES=0" mi_kitti "$KITTI"
for f in "$O"/after_*.txt; do
  name=$(basename "$f" .txt); name=${name#after_}
  cpu() { awk -F': ' '/User time|System time/ {s += $2} END {printf "%.1f", s}' "$1"; }
  rss() { awk -F': ' '/Maximum resident/ {printf "%.0f", $2 / 1024}' "$1"; }
  same=different
  if diff -q <(grep -o 'digest [0-9a-f]*' "$O/before_$name.txt") <(grep -o 'digest [0-9a-f]*' "$f") > /dev/null; then same=identical; fi
  echo "$name: CPU $(cpu "$O/before_$name.txt") -> $(cpu "$f") s, peak $(rss "$O/before_$name.txt") -> $(rss "$f") MiB, digests $same"
done
