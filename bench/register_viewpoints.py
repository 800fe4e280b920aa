#!/usr/bin/python3
"""Writes clouds/<m>.viewpoints.txt (sensor positions in each cloud's own frame) for a scene
folder that lacks them (`mmba simulate` writes them itself, with the LiDAR model's registered
rather than true station positions), for the free-space test of `mmba register-eval`.

A data provider has these natively: a scanner's stations in its registered model, the camera
centres of a multi-view reconstruction in its frame, the stereo stations of a spherical-stereo
reconstruction. The simulator records them in world coordinates in truth/truth.json; each
cloud is stored in its own frame (ground_truth.json world_from_<m>), so a sensor position c
is written as world_from_<m>^-1 c. Nothing else of the truth is used. The plane proxy is a
model without a sensor: no file.

usage: /usr/bin/python3 bench/register_viewpoints.py SCENE_DIR
"""
import json
import os
import sys

import numpy as np


def centre_of(from_world):
    m = np.array(from_world["matrix"], dtype=float)
    return -m[:3, :3].T @ m[:3, 3]


def main():
    scene = sys.argv[1]
    truth = json.load(open(os.path.join(scene, "truth", "truth.json")))
    gt = json.load(open(os.path.join(scene, "ground_truth.json")))
    world = {}
    scans = truth.get("lidar", {}).get("static_scans") or []
    world["lidar"] = [np.array(s["world_from_scan"]["matrix"], dtype=float)[:3, 3] for s in scans]
    stations = (truth.get("spherical_stereo") or {}).get("stations") or []
    world["spherical_stereo"] = [centre_of(s["lower_from_world"]) for s in stations]
    photos = (truth.get("photos") or {}).get("images") or []
    world["multi_view"] = [centre_of(p["cam_from_world"]) for p in photos]
    for name, centres in world.items():
        key = "world_from_" + name
        if key not in gt or not centres:
            continue
        w = np.array(gt[key], dtype=float)
        inv = np.linalg.inv(w)
        path = os.path.join(scene, "clouds", name + ".viewpoints.txt")
        with open(path, "w") as out:
            out.write("# sensor positions of clouds/%s.ply in its own frame (x y z, m), "
                      "from truth/truth.json via %s^-1\n" % (name, key))
            for c in centres:
                p = inv[:3, :3] @ c + inv[:3, 3]
                out.write("%.6f %.6f %.6f\n" % tuple(p))
        print(path, len(centres), "viewpoints")


if __name__ == "__main__":
    main()
