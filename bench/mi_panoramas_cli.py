#!/usr/bin/python3
"""MI registration of simulated panoramas through the command line a user types, on an
`mmba simulate` output.

For each simulated panorama (the spherical stations' lower and upper images, the rig's stitched
panoramas) it runs

    mmba register-mi --lidar SIM/truth/mobile_lidar_true.ply --image IMAGE \
        --camera SIM/truth/cameras/<kind>/<name>.yaml [--view perspective|image|cube] \
        --perturb tx,ty,tz,roll,pitch,yaw --output OUT.json

— nothing else: the camera YAML (written by the simulator) holds the true pose, `--perturb`
starts the search from it corrected by a random draw, and the mobile cloud's sidecar
(truth/mobile_lidar_true.scanner.yaml) gives the scanner's positions for the incidence
correction. Draws as bench/mi_panoramas: each component uniform in +-max, "small" 0.1 m / 1 deg
(the paper's typical corrections), "large" 0.3 m / 2 deg. A run is "right" when the median
pixel offset of the true correspondences (register-mi's pixel_offset_vs_reference, the visible
LiDAR points projected with the result against the truth) is below 1 px in every view
registered, in that view's own pixels: a perspective cut (940x452, 90 deg) has 2.9x the
1024-wide panorama's resolution; --view image is the whole panorama; a cube face (512 px,
90 deg) 1.6x.

Usage:
  /usr/bin/python3 bench/mi_panoramas_cli.py MMBA SIM OUTDIR [--draws N] [--seed S]
      [--view auto|perspective|image|cube] [--extra "OPTIONS"] [--summarize]
Writes OUTDIR/runs.csv and one JSON per run; prints a summary; and, as Wang et al.'s histograms of
pixel offsets before and after, OUTDIR/hist_{small,large,all}.{csv,svg}: each registration's
median offset (worst view, the view's own pixels) at the start and at the end, 1 px bins.
"""
import argparse
import csv
import glob
import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mi_panoramas_summary import write_histogram  # noqa: E402

SIZES = {"small": (0.1, 1.0), "large": (0.3, 2.0)}


def summarize(rows):
    print("| size | runs | ok | ok and right | refused but right | wrong ok | right (any status) | "
          "median offset before -> after (px, worst cut) | wall s (median) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for size in list(SIZES) + ["all"]:
        r = [x for x in rows if size == "all" or x["size"] == size]
        if not r:
            continue
        ok = [x for x in r if x["status"] == "ok"]
        right = [x for x in r if float(x["after_px"]) < 1.0]
        print("| %s | %d | %d | %d | %d | %d | %d | %.2f -> %.2f | %.1f |" % (
            size, len(r), len(ok), sum(float(x["after_px"]) < 1.0 for x in ok),
            sum(x["status"] != "ok" and float(x["after_px"]) < 1.0 for x in r),
            sum(float(x["after_px"]) >= 1.0 for x in ok), len(right),
            np.median([float(x["before_px"]) for x in r]), np.median([float(x["after_px"]) for x in r]),
            np.median([float(x["wall_s"]) for x in r])))


def write_histograms(out_dir, rows):
    """Before/after histograms per start size and over all (the paper's Figs. 12-13 kind)."""
    for size in list(SIZES) + ["all"]:
        r = [x for x in rows if size == "all" or x["size"] == size]
        if not r:
            continue
        label = "all starts" if size == "all" else "starts up to %g m / %g deg" % SIZES[size]
        write_histogram(pathlib.Path(out_dir) / ("hist_" + size),
                        "%s: %s, %d registrations (after: every status)" % (
                            os.path.basename(os.path.normpath(out_dir)), label, len(r)),
                        [float(x["before_px"]) for x in r], [float(x["after_px"]) for x in r],
                        bin_px=1.0, bins=40, unit="px of the view registered")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mmba")
    parser.add_argument("sim")
    parser.add_argument("out")
    parser.add_argument("--draws", type=int, default=1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--view", default="auto", help="register-mi --view (auto, the default: perspective for a panorama | perspective | image | cube)")
    parser.add_argument("--extra", default="", help="more register-mi options, space-separated")
    parser.add_argument("--summarize", action="store_true", help="only summarise OUTDIR/runs.csv")
    args = parser.parse_args()
    if args.summarize:
        rows = list(csv.DictReader(open(os.path.join(args.out, "runs.csv"))))
        summarize(rows)
        write_histograms(args.out, rows)
        return
    os.makedirs(args.out, exist_ok=True)
    cloud = os.path.join(args.sim, "truth", "mobile_lidar_true.ply")
    views = []
    for kind in ("spherical", "rig_panoramas"):
        for yaml in sorted(glob.glob(os.path.join(args.sim, "truth", "cameras", kind, "*.yaml"))):
            name = os.path.splitext(os.path.basename(yaml))[0]
            views.append((kind, name, os.path.join(args.sim, "images", kind, name + ".png"), yaml))
    if not views:
        sys.exit("no SIM/truth/cameras/{spherical,rig_panoramas}/*.yaml: simulate with this mmba")
    rng = np.random.default_rng(args.seed)
    rows = []
    for kind, name, image, yaml in views:
        for size, (max_m, max_deg) in SIZES.items():
            for draw in range(args.draws):
                p = np.concatenate([rng.uniform(-max_m, max_m, 3), rng.uniform(-max_deg, max_deg, 3)])
                out = os.path.join(args.out, "%s_%s_%d.json" % (name, size, draw))
                cmd = [args.mmba, "register-mi", "--lidar", cloud, "--image", image, "--camera", yaml,
                       "--view", args.view, "--perturb", ",".join("%.6f" % v for v in p),
                       "--output", out, "-q"] + args.extra.split()
                start = time.time()
                run = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.time() - start
                if run.returncode not in (0, 3):
                    sys.exit("exit %d: %s\n%s" % (run.returncode, " ".join(cmd), run.stderr))
                r = json.load(open(out))
                offsets = r["pixel_offset_vs_reference"]
                row = {"kind": kind, "view": name, "size": size, "draw": draw,
                       "perturb": " ".join("%.6f" % v for v in p), "status": r["status"],
                       "before_px": max(o["before"]["median_px"] for o in offsets),
                       "after_px": max(o["after"]["median_px"] for o in offsets),
                       "wall_s": round(wall, 2), "reason": (r["reason"] or "")[:200]}
                rows.append(row)
                print("%-14s %-10s %-5s %d: %-6s %6.2f -> %6.2f px  %5.1f s" % (
                    kind, name, size, draw, row["status"], row["before_px"], row["after_px"], wall), flush=True)
    with open(os.path.join(args.out, "runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    summarize([{k: str(v) for k, v in x.items()} for x in rows])
    write_histograms(args.out, rows)


if __name__ == "__main__":
    main()
