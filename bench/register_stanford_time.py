#!/usr/bin/python3
"""Whole process against whole process on the Stanford pairs: `mmba register-cloud` with
default settings and Open3D's FPFH + RANSAC + point-to-plane ICP (bench/register_open3d.py,
2 mm voxels), interleaved run by run, each timed by /usr/bin/time (wall, user + sys CPU, peak
RSS) and its result checked against bun.conf (+ the zipper reconstruction at identity).

usage: bench/register_stanford_time.py BUILD_DIR [--runs N] [--data DIR]
(DATA default ../shared/data/pointclouds/stanford_bunny next to the repository). Run it on an
otherwise idle machine: under load Open3D's OpenMP threads spin and it looks slower.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
from stanford_conf import pose_error, truth  # noqa: E402

args = sys.argv[1:]
if not args or args[0].startswith("-"):
    sys.exit(__doc__)
build = args[0]
runs = int(args[args.index("--runs") + 1]) if "--runs" in args else 2
data = args[args.index("--data") + 1] if "--data" in args else os.path.join(
    here, "..", "..", "shared", "data", "pointclouds", "stanford_bunny")
pairs = [("bun045", "bun000"), ("bun000", "bun045"), ("bun000", "bun_zipper_res2"),
         ("bun045", "bun_zipper_res2"), ("bun_zipper_res2", "bun000"),
         ("bun_zipper_res2", "bun045")]

work = tempfile.mkdtemp(prefix="stanford_time_")
conf = os.path.join(work, "bun.conf")
with open(conf, "w") as out:
    out.write(open(os.path.join(data, "bun.conf")).read())
    out.write("bmesh bun_zipper_res2.ply 0 0 0 0 0 0 1\n")


def timed(command):
    """(stdout, wall s, CPU s, peak RSS MiB) of a command run under /usr/bin/time."""
    stats = os.path.join(work, "time.txt")
    p = subprocess.run(["/usr/bin/time", "-o", stats, "-f", "%e %U %S %M"] + command,
                       capture_output=True, text=True)
    wall, user, system, rss = open(stats).read().split()[-4:]
    return p, float(wall), float(user) + float(system), float(rss) / 1024


rows = {}
for run in range(runs):
    for s, t in pairs:
        src, tgt = os.path.join(data, s + ".ply"), os.path.join(data, t + ".ply")
        out = os.path.join(work, "out.json")
        p, wall, cpu, rss = timed([os.path.join(build, "apps", "mmba"), "register-cloud",
                                   "--source", src, "--target", tgt, "--output", out, "-q"])
        j = json.load(open(out))
        attempt = j["target_from_source"] or j.get("failed_attempt_target_from_source")
        est = np.array(attempt if attempt else np.full((4, 4), np.nan), dtype=float).reshape(4, 4)
        angle, dt = pose_error(est, truth(conf, src, tgt))
        rows.setdefault((s, t, "mmba"), []).append((wall, cpu, rss, angle, dt, j["status"]))
        p, wall, cpu, rss = timed(["/usr/bin/python3", os.path.join(here, "register_open3d.py"),
                                   src, tgt, "0.002", "--conf", conf])
        line = [l for l in p.stdout.splitlines() if l.startswith("error vs")][0].split()
        angle, dt = float(line[4]), float(line[7]) / 1000
        rows.setdefault((s, t, "open3d"), []).append((wall, cpu, rss, angle, dt, "-"))
        print(f"run {run}: {s} -> {t} done", file=sys.stderr)

print("| pair | mmba error | Open3D error | mmba wall / CPU s | Open3D wall / CPU s | "
      "peak RSS MiB mmba / Open3D |")
print("|---|---|---|---|---|---|")
means = {"mmba": ([], []), "open3d": ([], [])}
for s, t in pairs:
    cells = []
    for tool in ("mmba", "open3d"):
        r = rows[(s, t, tool)]
        means[tool][0].extend(x[0] for x in r)
        means[tool][1].extend(x[1] for x in r)
        cells.append(r)
    m, o = cells
    status = "" if all(x[5] == "ok" for x in m) else " (" + ",".join(x[5] for x in m) + ")"

    def span(values):
        lo, hi = min(values), max(values)
        return f"{lo:.2f}" if f"{lo:.2f}" == f"{hi:.2f}" else f"{lo:.2f}–{hi:.2f}"

    print(f"| {s} → {t} | {m[0][3]:.3f}° / {1000 * m[0][4]:.3f} mm{status} | "
          f"{o[0][3]:.3f}° / {1000 * o[0][4]:.3f} mm | {span([x[0] for x in m])} / "
          f"{span([x[1] for x in m])} | {span([x[0] for x in o])} / {span([x[1] for x in o])} | "
          f"{max(x[2] for x in m):.0f} / {max(x[2] for x in o):.0f} |")
for tool, (wall, cpu) in means.items():
    print(f"{tool}: mean wall {statistics.mean(wall):.3f} s, mean CPU {statistics.mean(cpu):.3f} s "
          f"over {len(wall)} runs")
