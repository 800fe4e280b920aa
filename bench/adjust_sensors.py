#!/usr/bin/env python3
"""Bench: `mmba adjust` on a simulated scene with every sensor, then with one
sensor group removed at a time — does each sensor add the information it should?

  bench/adjust_sensors.py MMBA_BINARY SCENE PRESET WORK_DIR     e.g. build/apps/mmba cathedral small /tmp/adj

Prints a Markdown table (check-point RMSE against the RMSE the propagated covariances
predict, photo-pose and sphere-station errors against the simulator's truth, sigma0, time,
peak memory) for bench/RESULTS.md.
"""
import json
import os
import re
import subprocess
import sys
import time

import yaml

def variant(base, sim, name, drop_types=(), settings=None):
    p = dict(base)
    p["sensors"] = [dict(s) for s in base["sensors"] if s["type"] not in drop_types]
    if "total_station" in drop_types:  # no control and no check points without the network
        p.pop("check_points", None)
        for s in p["sensors"]:
            s.pop("control_measurements", None)
    if "camera_rig" in drop_types:  # the mobile LiDAR then has no rig: body_from_lidar held
        for s in p["sensors"]:
            s.pop("rig", None)
    if settings:
        p["adjustment"] = settings
    path = os.path.join(sim, f"project_{name}.yaml")
    with open(path, "w") as f:
        yaml.safe_dump(p, f, sort_keys=False)
    return path


def summarise(out):
    """The truth-evaluation columns of one adjustment's output folder, as Markdown cells."""
    r = json.load(open(os.path.join(out, "report.json")))
    t = r.get("truth_evaluation", {})
    c = r.get("check_summary", {})
    check = f"{1000 * c['rmse_3d']:.1f} mm ({1000 * c['expected_rmse_3d']:.1f} mm, n={c['count']})" if c else "-"
    pp = t.get("photo_positions", {})
    photos = f"{1000 * pp['rmse_m']:.1f} / {1000 * pp['max_m']:.1f} mm" if pp else "-"
    sp = t.get("spheres")
    sphere = f"{1000 * sp['max_position_m']:.1f} mm" if sp else "-"
    rg = t.get("rig")
    rig = f"{1000 * rg['max_frame_position_m']:.1f} mm (prior {1000 * rg['max_prior_position_m']:.0f} mm)" if rg else "-"
    s0 = f"{r['sigma0']['aposteriori']:.3f} ({r['sigma0_given_weights']['aposteriori']:.3f})"
    ml = t.get("mobile_lidar", {})
    ext = (f"{1000 * ml['rig_from_lidar']['translation_m']:.1f} mm, {ml['rig_from_lidar']['rotation_deg']:.3f}°"
           if "rig_from_lidar" in ml else "-")
    tr = ml.get("trajectory")
    traj = f"{1000 * tr['rmse_position_m']:.1f} mm ({1000 * tr['ins_rmse_position_m']:.0f} mm)" if tr else "-"
    sc = t.get("static_scans")
    scans = (f"{1000 * sc['max_position_m']:.1f} mm / {sc['max_rotation_deg']:.3f}° "
             f"({1000 * sc['registration_max_position_m']:.1f} mm / {sc['registration_max_rotation_deg']:.3f}°)" if sc else "-")
    return {"check": check, "photos": photos, "sphere": sphere, "rig": rig, "ext": ext, "traj": traj, "scans": scans,
            "s0": s0, "blunders": len(r["blunders"]), "report": r}


def main():
    mmba, scene, preset, work = sys.argv[1:5]
    sim = os.path.join(work, "sim")
    if not os.path.exists(os.path.join(sim, "project.yaml")):
        subprocess.run([mmba, "simulate", "--scene", scene, "--preset", preset, "--out", sim, "-q"], check=True)
    base = yaml.safe_load(open(os.path.join(sim, "project.yaml")))
    variants = [
        ("all sensors", variant(base, sim, "all")),
        ("without static LiDAR (and so without the mobile LiDAR)", variant(base, sim, "nolidar", ["lidar_static", "lidar_mobile"])),
        ("without mobile LiDAR", variant(base, sim, "nomobile", ["lidar_mobile"])),
        ("without spherical stereo", variant(base, sim, "nosphere", ["spherical_stereo"])),
        ("without camera rig", variant(base, sim, "norig", ["camera_rig"])),
        ("without GNSS control", variant(base, sim, "nognss", ["gnss"])),
        ("without total station (no control, no check points)", variant(base, sim, "nots", ["total_station"])),
        ("all, no variance components", variant(base, sim, "novce", settings={"variance_components": False})),
    ]
    print("| run | check RMSE 3D (expected) | photo pos RMSE / max | sphere max pos | rig frame max pos | rig_from_lidar error | trajectory RMSE (GNSS/INS) | scans max pos / rot (registration) | sigma0 (given σ) | blunders | time | peak RSS |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for label, path in variants:
        out = os.path.join(work, "out_" + os.path.basename(path)[8:-5])
        start = time.time()
        run = subprocess.run(["/usr/bin/time", "-v", mmba, "adjust", path, "--output", out, "-q"],
                             capture_output=True, text=True)
        seconds = time.time() - start
        with open(out + ".summary.txt", "w") as f:
            f.write(run.stdout)
        rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
        rss = f"{int(rss.group(1)) / 1024:.0f} MB" if rss else "?"
        if run.returncode != 0:
            reason = run.stderr.strip().splitlines()[0] if run.stderr.strip() else "?"
            print(f"| {label} | failed (exit {run.returncode}): {reason} | | | | | | | | | {seconds:.0f} s | {rss} |")
            continue
        c = summarise(out)
        print(f"| {label} | {c['check']} | {c['photos']} | {c['sphere']} | {c['rig']} | {c['ext']} | {c['traj']} | {c['scans']} | {c['s0']} | {c['blunders']} | {seconds:.0f} s | {rss} |",
              flush=True)


if __name__ == "__main__":
    main()
