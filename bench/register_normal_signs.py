#!/usr/bin/python3
"""Which way do a simulated scene's estimated normals point when turned towards each cloud's
frame origin (PCL's viewpoint convention, what register-cloud did without sensor positions)?

For the LiDAR model, the multi-view and the spherical-stereo cloud of a `mmba simulate` folder:
normals within 0.4 m on a 0.1 m voxel grid (Open3D), turned towards the cloud's own origin,
then compared in the world frame (truth/truth.json). Prints the share of horizontal surfaces
(|n_z| > 0.9) and the share of those pointing down, with the origin and the sensors' heights.
usage: register_normal_signs.py SIM_DIR [SIM_DIR ...]
"""
import json
import sys

import numpy as np
import open3d as o3d

for scene in sys.argv[1:]:
    reg = json.load(open(f"{scene}/truth/truth.json"))["registration"]
    for name in ("lidar", "multi_view", "spherical_stereo"):
        pc = o3d.io.read_point_cloud(f"{scene}/clouds/{name}.ply").voxel_down_sample(0.1)
        pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.4, max_nn=40))
        pc.orient_normals_towards_camera_location(np.zeros(3))
        w = np.array(reg["world_from_" + name])
        n = np.asarray(pc.normals) @ w[:3, :3].T
        horizontal = np.abs(n[:, 2]) > 0.9
        sensors = np.loadtxt(f"{scene}/clouds/{name}.viewpoints.txt", ndmin=2) @ w[:3, :3].T + w[:3, 3]
        print(f"{scene}: {name}: origin at z {w[2, 3]:.2f} m (world), sensors at z "
              f"{np.round(np.unique(np.round(sensors[:, 2], 1)), 1)}; horizontal {horizontal.mean():.2f}"
              f" of the normals, {np.mean(n[horizontal, 2] < 0):.2f} of them pointing down")
