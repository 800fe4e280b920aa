#!/usr/bin/env python3
"""Writes a large plane survey network as a survey CSV (mmba survey --input), for the memory
benchmark of `mmba survey` (bench/RESULTS.md, "Survey: memory of a large network").

A grid of COLS × ROWS points 100 m apart (approximations 0.05 m off the truth), the four
corners fixed, every point a station with one direction set to its 4 grid neighbours and
distances to its right and upper neighbours: about 6 observations per point.

  bench/survey_large_csv.py OUT.csv [COLS] [ROWS] [SEED]
"""
import math
import random
import sys


def main():
    out = sys.argv[1]
    cols = int(sys.argv[2]) if len(sys.argv) > 2 else 58
    rows = int(sys.argv[3]) if len(sys.argv) > 3 else 58
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 1)
    spacing = 100.0
    sigma_dir_cc, sigma_dist_mm = 10.0, 3.0

    def name(c, r):
        return f"P{c}_{r}"

    truth = {(c, r): (c * spacing, r * spacing) for c in range(cols) for r in range(rows)}
    corners = {(0, 0), (cols - 1, 0), (0, rows - 1), (cols - 1, rows - 1)}
    lines = ["param,sigma-apr,10", "param,axes-xy,en"]
    for (c, r), (x, y) in truth.items():
        if (c, r) in corners:
            lines.append(f"point,{name(c, r)},{x:.4f},{y:.4f},,xy,")
        else:
            lines.append(f"point,{name(c, r)},{x + rng.gauss(0, 0.05):.4f},"
                         f"{y + rng.gauss(0, 0.05):.4f},,,xy")
    count = 0
    for (c, r), (x, y) in truth.items():
        neighbours = [(c + dc, r + dr) for dc, dr in ((1, 0), (0, 1), (-1, 0), (0, -1))
                      if (c + dc, r + dr) in truth]
        orientation = rng.uniform(0, 400)
        lines.append(f"set,{name(c, r)}")
        for n in neighbours:
            tx, ty = truth[n]
            azimuth = math.degrees(math.atan2(tx - x, ty - y)) / 0.9  # gon, from +y (north)
            value = (azimuth - orientation + rng.gauss(0, sigma_dir_cc / 1e4)) % 400
            lines.append(f"direction,{name(c, r)},{name(*n)},{value:.6f},{sigma_dir_cc}")
            count += 1
        for n in ((c + 1, r), (c, r + 1)):
            if n in truth:
                tx, ty = truth[n]
                d = math.hypot(tx - x, ty - y) + rng.gauss(0, sigma_dist_mm / 1e3)
                lines.append(f"distance,{name(c, r)},{name(*n)},{d:.4f},{sigma_dist_mm}")
                count += 1
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"{out}: {cols * rows} points, {count} observations")


if __name__ == "__main__":
    main()
