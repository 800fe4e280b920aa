#!/usr/bin/env bash
# mmba ba against colmap bundle_adjuster on the same COLMAP model, perturbed.
#   bench/colmap_ba_compare.sh [MODEL_DIR] [BUILD_DIR]
# Perturbs the model (poses 0.01 rad / 0.05 units, points 0.05 units; seed 1), then runs
# both adjusters with the same refinement (focal + extra, no principal point, no loss,
# 100 iterations, 2 threads) and prints final RMS reprojection error and wall time.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
model="${1:-$root/data/colmap/balbianello/sparse}"
build="${2:-$root/build}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
export QT_QPA_PLATFORM=offscreen
"$build/bench/colmap_tools" perturb "$model" "$work/start" 0.01 0.05 0.05 1
# COLMAP reads and writes binary or text; give it the same text model.
mkdir -p "$work/colmap_out" "$work/mmba_out"
read -r rms0 mean0 n0 < <("$build/bench/colmap_tools" rms "$work/start")
t0=$(date +%s.%N)
colmap bundle_adjuster --input_path "$work/start" --output_path "$work/colmap_out" \
  --BundleAdjustment.max_num_iterations 100 --BundleAdjustment.refine_focal_length 1 \
  --BundleAdjustment.refine_principal_point 0 --BundleAdjustment.refine_extra_params 1 \
  > "$work/colmap.log" 2>&1
t1=$(date +%s.%N)
"$build/apps/mmba" ba --input "$work/start" --output "$work/mmba_out" --refine-focal \
  --refine-extra --max-iterations 100 --threads 2 --quiet > "$work/mmba.log" 2>&1
t2=$(date +%s.%N)
read -r rms_c mean_c n_c < <("$build/bench/colmap_tools" rms "$work/colmap_out")
read -r rms_m mean_m n_m < <("$build/bench/colmap_tools" rms "$work/mmba_out")
printf "model: %s (%s observations)\n" "$model" "$n0"
printf "start:                  RMS %.4f px, mean %.4f px\n" "$rms0" "$mean0"
printf "colmap bundle_adjuster: RMS %.4f px, mean %.4f px, wall %.2f s\n" "$rms_c" "$mean_c" \
  "$(echo "$t1 - $t0" | bc)"
printf "mmba ba:                RMS %.4f px, mean %.4f px, wall %.2f s\n" "$rms_m" "$mean_m" \
  "$(echo "$t2 - $t1" | bc)"
