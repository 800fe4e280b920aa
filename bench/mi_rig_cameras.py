#!/usr/bin/python3
"""MI registration of a simulated Ladybug-style rig through its own cameras (`register-mi --rig`).

For each rig frame of an `mmba simulate` output, the frame's camera images (images/rig/
<frame>_<camera>.png) are registered as the views of one rig pose against the mobile LiDAR at
its true positions (truth/mobile_lidar_true.ply, world frame), from the true rig_from_world
perturbed by random corrections of up to 0.1 m / 1° ("small", the paper's typical) and up to
0.3 m / 2° ("large"), each component uniform in ±max (the bench mi_panoramas draws the same
way). The pixel offsets of the LiDAR points projected with the result against the truth come
from register-mi's own `--perturb` report (per camera: median over the camera's visible
points). A registration is "right" when every camera's median offset is below 1 px.

Usage:
  /usr/bin/python3 bench/mi_rig_cameras.py MMBA SIM OUTDIR [--calib nominal|true] [--draws N]
      [--seed S] [--frames frame_000,frame_001] [--extra "OPTIONS"] [--summarize]
--calib nominal: SIM/calib/ladybug.yaml (design intrinsics, factory cam_from_rig: what a user
has); true: the simulator's true intrinsics and cam_from_rig from truth/truth.json.
The mobile cloud's intensity is corrected for the angle of incidence when register-mi knows the
scanner: the simulator writes the sidecar truth/mobile_lidar_true.scanner.yaml (corrected by
default); a folder without it needs --extra "--trajectory … --lidar-mount …".
--extra "--incidence-correction off" gives the intensity as measured.
Writes OUTDIR/runs.csv and OUTDIR/<frame>_<size>_<draw>.json and prints a summary.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import time

import numpy as np


def write_true_rig(truth, path):
    with open(path, "w") as out:
        out.write("# true intrinsics and cam_from_rig from truth/truth.json\ncameras:\n")
        for k, cam in enumerate(truth["rig"]["cameras"]):
            c = cam["camera"]
            q = cam["cam_from_rig"]["qvec_wxyz"]
            t = cam["cam_from_rig"]["tvec"]
            out.write("  - name: cam%d\n    model: %s\n    width: %d\n    height: %d\n" %
                      (k, c["model"], c["width"], c["height"]))
            out.write("    params: [%s]\n" % ", ".join(repr(float(v)) for v in c["params"]))
            out.write("    cam_from_rig: {qvec_wxyz: [%s], tvec: [%s]}\n" %
                      (", ".join(repr(float(v)) for v in q), ", ".join(repr(float(v)) for v in t)))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mmba")
    parser.add_argument("sim")
    parser.add_argument("out")
    parser.add_argument("--calib", default="nominal", choices=["nominal", "true"])
    parser.add_argument("--draws", type=int, default=2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--frames", default="")
    parser.add_argument("--summarize", action="store_true", help="only summarise OUTDIR/runs.csv")
    parser.add_argument("--extra", default="", help="more register-mi options, space-separated")
    args = parser.parse_args()
    if args.summarize:
        summarize(list(csv.DictReader(open(os.path.join(args.out, "runs.csv")))))
        return
    os.makedirs(args.out, exist_ok=True)
    truth = json.load(open(os.path.join(args.sim, "truth", "truth.json")))
    if args.calib == "true":
        rig = os.path.join(args.out, "rig_true.yaml")
        write_true_rig(truth, rig)
    else:
        rig = os.path.join(args.sim, "calib", "ladybug.yaml")
    cloud = os.path.join(args.sim, "truth", "mobile_lidar_true.ply")
    frames = truth["rig"]["frames"]
    if args.frames:
        wanted = args.frames.split(",")
        frames = [f for f in frames if f["name"] in wanted]
    rng = np.random.default_rng(args.seed)
    rows = []
    for frame in frames:
        name = frame["name"]
        pose = os.path.join(args.out, name + "_pose.json")
        json.dump({"rig_from_lidar": frame["rig_from_world"]["matrix"]}, open(pose, "w"))
        for size, max_m, max_deg in (("small", 0.1, 1.0), ("large", 0.3, 2.0)):
            for draw in range(args.draws):
                p = np.concatenate([rng.uniform(-max_m, max_m, 3), rng.uniform(-max_deg, max_deg, 3)])
                out = os.path.join(args.out, "%s_%s_%d.json" % (name, size, draw))
                command = [args.mmba, "register-mi", "--rig", rig, "--lidar", cloud,
                           "--image", os.path.join(args.sim, "images", "rig", name + "_{camera}.png"),
                           "--initial", pose, "--perturb", ",".join("%.6f" % v for v in p),
                           "--output", out, "-q"] + args.extra.split()
                start = time.time()
                run = subprocess.run(command, capture_output=True, text=True)
                wall = time.time() - start
                if run.returncode not in (0, 3):
                    sys.exit("%s: exit %d\n%s" % (" ".join(command), run.returncode, run.stderr))
                result = json.load(open(out))
                offsets = result["pixel_offset_vs_reference"]
                before = [o["before"]["median_px"] for o in offsets]
                after = [o["after"]["median_px"] for o in offsets]
                rows.append({"frame": name, "size": size, "draw": draw,
                             "perturbation": " ".join("%.3f" % v for v in p),
                             "status": result["status"], "cameras": len(offsets),
                             "before_max_px": max(before), "after_max_px": max(after),
                             "after_median_px": float(np.median(after)),
                             "right": int(max(after) < 1.0), "wall_s": wall,
                             "reason": result["reason"][:160]})
                print("%s %s %d: %s, camera medians %s px -> %s px, %.1f s" %
                      (name, size, draw, result["status"], " ".join("%.2f" % v for v in before),
                       " ".join("%.2f" % v for v in after), wall), flush=True)
    with open(os.path.join(args.out, "runs.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    summarize(rows)


def summarize(rows):
    """Two readings of "< 1 px": every camera's median (strict), or the frame's median over its
    cameras' medians (the rig frame as one view)."""
    print("\n| starts | registrations | ok | ok, every camera < 1 px | ok, a camera >= 1 px "
          "| ok, frame median < 1 px | all, frame median < 1 px | worst camera of an ok | median s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for size in ("small", "large"):
        r = [x for x in rows if x["size"] == size]
        ok = [x for x in r if x["status"] == "ok"]
        print("| %s | %d | %d | %d | %d | %d | %d | %s | %.1f |" % (
            "0.1 m / 1°" if size == "small" else "0.3 m / 2°", len(r), len(ok),
            sum(int(x["right"]) for x in ok), sum(1 - int(x["right"]) for x in ok),
            sum(float(x["after_median_px"]) < 1 for x in ok),
            sum(float(x["after_median_px"]) < 1 for x in r),
            "%.2f px" % max(float(x["after_max_px"]) for x in ok) if ok else "–",
            float(np.median([float(x["wall_s"]) for x in r]))))


if __name__ == "__main__":
    main()
