#!/usr/bin/env bash
# Bench: COLMAP's own SIFT feature extraction, exhaustive matching and incremental
# mapping on the photo collection of a simulated scene, then a similarity alignment of the
# reconstructed camera centres to the true ones (colmap model_aligner) to measure how well
# real detection works on the renders.
#   bench/sim_colmap_reconstruct.sh SIM_DIR WORK_DIR
set -euo pipefail
sim=${1:?simulated folder (mmba simulate --out)}
work=${2:?work folder}
threads=${THREADS:-2}
mkdir -p "$work/sparse" "$work/aligned"
db="$work/database.db"
rm -f "$db"
start=$(date +%s.%N)
colmap feature_extractor --database_path "$db" --image_path "$sim/images/photos" \
  --ImageReader.single_camera 1 --ImageReader.camera_model OPENCV \
  --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads "$threads" > "$work/extract.log" 2>&1
colmap exhaustive_matcher --database_path "$db" --SiftMatching.use_gpu 0 \
  --SiftMatching.num_threads "$threads" > "$work/match.log" 2>&1
colmap mapper --database_path "$db" --image_path "$sim/images/photos" --output_path "$work/sparse" \
  --Mapper.num_threads "$threads" > "$work/mapper.log" 2>&1
end=$(date +%s.%N)
# True camera centres (world frame) from the true COLMAP model: C = -R^T t.
awk 'BEGIN{n=0} /^#/ {next} { n++; if (n % 2 == 1) {
  qw=$2; qx=$3; qy=$4; qz=$5; tx=$6; ty=$7; tz=$8;
  r00=1-2*(qy*qy+qz*qz); r01=2*(qx*qy-qz*qw); r02=2*(qx*qz+qy*qw);
  r10=2*(qx*qy+qz*qw); r11=1-2*(qx*qx+qz*qz); r12=2*(qy*qz-qx*qw);
  r20=2*(qx*qz-qy*qw); r21=2*(qy*qz+qx*qw); r22=1-2*(qx*qx+qy*qy);
  cx=-(r00*tx+r10*ty+r20*tz); cy=-(r01*tx+r11*ty+r21*tz); cz=-(r02*tx+r12*ty+r22*tz);
  printf "%s %.6f %.6f %.6f\n", $10, cx, cy, cz } }' \
  "$sim/truth/colmap_photos/images.txt" > "$work/true_centres.txt"
colmap model_analyzer --path "$work/sparse/0" 2>&1 | tee "$work/analyzer.log" | grep -E "Registered images|Points|Observations|Mean reprojection" || true
colmap model_aligner --input_path "$work/sparse/0" --output_path "$work/aligned" \
  --ref_images_path "$work/true_centres.txt" --ref_is_gps 0 --alignment_type custom \
  --robust_alignment 1 --robust_alignment_max_error 0.5 > "$work/align.log" 2>&1 || true
grep -iE "error|residual|Aligning" "$work/align.log" | tail -5 || true
printf 'wall time extract+match+map: %.1f s\n' "$(echo "$end - $start" | bc)"
