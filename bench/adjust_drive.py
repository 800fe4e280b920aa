#!/usr/bin/env python3
"""Bench (scale): `mmba adjust` on the simulated drive — 200 rig frames and panoramas,
>= 50 M mobile LiDAR points — with time and peak memory; and the same project of a smaller
drive with the large cloud swapped in, to show that memory does not grow with the cloud.

  bench/adjust_drive.py MMBA_BINARY WORK_DIR [SMALL_FRAMES]      e.g. build/apps/mmba /tmp/drive 40

Steps whose output exists are not run again (WORK/full, WORK/small: simulations;
WORK/out_*: adjustments, with WORK/out_*.time.txt from /usr/bin/time -v). The small drive is
the same 100 m drive (same seed: the same trajectory and GNSS/INS) with SMALL_FRAMES rig frames
and a 0.6° LiDAR step. Prints a Markdown table for bench/RESULTS.md.
"""
import os
import re
import subprocess
import sys

from adjust_sensors import summarise


def run_timed(args, log):
    if not os.path.exists(log):
        run = subprocess.run(["/usr/bin/time", "-v"] + args, capture_output=True, text=True)
        with open(log, "w") as f:
            f.write(run.stdout + run.stderr)
    text = open(log).read()
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) / 1024
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text).group(1)
    cpu = float(re.search(r"User time \(seconds\): ([\d.]+)", text).group(1)) + \
        float(re.search(r"System time \(seconds\): ([\d.]+)", text).group(1))
    status = int(re.search(r"Exit status: (\d+)", text).group(1))
    return rss, wall, cpu, status


def main():
    mmba, work = sys.argv[1:3]
    small_frames = int(sys.argv[3]) if len(sys.argv) > 3 else 40
    os.makedirs(work, exist_ok=True)
    full, small = os.path.join(work, "full"), os.path.join(work, "small")
    rows = [("simulate drive", run_timed([mmba, "simulate", "--scene", "cathedral", "--preset", "drive", "--out", full, "-q"],
                                         full + ".time.txt"), None)]
    scene = os.path.join(work, "small.yaml")
    with open(scene, "w") as f:
        f.write(f"scene: cathedral\npreset: drive\nrig:\n  frames: {small_frames}\nlidar:\n  mobile_azimuth_step_deg: 0.6\n")
    rows.append((f"simulate drive, {small_frames} frames, 0.6° LiDAR step",
                 run_timed([mmba, "simulate", "--scene", scene, "--out", small, "-q"], small + ".time.txt"), None))
    # The small drive's project with the full drive's cloud (same trajectory file, same seed).
    project = open(os.path.join(small, "project.yaml")).read()
    big_cloud = os.path.abspath(os.path.join(full, "clouds", "mobile_lidar.ply"))
    swapped = os.path.join(small, "project_big_cloud.yaml")
    with open(swapped, "w") as f:
        f.write(project.replace("cloud: clouds/mobile_lidar.ply", "cloud: " + big_cloud))
    for label, path, out in [(f"adjust, {small_frames} frames, its own cloud", os.path.join(small, "project.yaml"), "out_small"),
                             (f"adjust, {small_frames} frames, the 200-frame drive's cloud", swapped, "out_small_big_cloud"),
                             ("adjust, 200 frames, its own cloud", os.path.join(full, "project.yaml"), "out_full")]:
        out = os.path.join(work, out)
        rows.append((label, run_timed([mmba, "adjust", path, "--output", out, "-q"], out + ".time.txt"), out))
    print("| step | mobile points | wall | CPU | peak RSS | check RMSE 3D (expected) | photo pos RMSE / max | "
          "rig frame max pos | rig_from_lidar error | trajectory RMSE (GNSS/INS) | sigma0 (given σ) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, (rss, wall, cpu, status), out in rows:
        if out is None or status != 0:
            print(f"| {label}{'' if status == 0 else f' (exit {status})'} | | {wall} | {cpu:.0f} s | {rss:.0f} MB | | | | | | |")
            continue
        c = summarise(out)
        points = c["report"]["mobile_lidar"]["points"]
        print(f"| {label} | {points / 1e6:.1f} M | {wall} | {cpu:.0f} s | {rss:.0f} MB | {c['check']} | {c['photos']} | "
              f"{c['rig']} | {c['ext']} | {c['traj']} | {c['s0']} |")


if __name__ == "__main__":
    main()
