#!/usr/bin/python3
"""How close to the truth can a least-squares fit bring the simulated spherical-stereo cloud?

The cathedral's stereo cells end 7-35 cm off even when `register-eval`'s reference starts at the
truth (bench/RESULTS.md, "What the data allow"). This checks whether that is the verifier's or
the ICP's doing, or the data's: the stereo cloud (or its part) is put at its true pose on a
target model, and two ICPs run from there, 40 iterations each:
  plain   - trimmed point-to-plane ICP (Chen & Medioni 1991), correspondences within DMAX m;
  oracle  - the simulator's own noise model: each point's residual taken along its ray from
            the nearest station, weighted by 1/sigma_r^2 with sigma_r = r^2 sigma_d / (f b sin
            theta) (the model in truth.json, simulate.cc), kept within K sigma_r;
            i.e. maximum likelihood for range noise, with the true sigmas.
Printed: the RMS displacement of the source's points from their true place at the end, and the
share of the source used. usage:
  register_stereo_bias.py SCENE [SOURCE [TARGET]]     (default spherical_stereo lidar)
"""
import json
import sys

import numpy as np
import open3d as o3d

scene = sys.argv[1]
src_name = sys.argv[2] if len(sys.argv) > 2 else "spherical_stereo"
tgt_name = sys.argv[3] if len(sys.argv) > 3 else "lidar"
truth = json.load(open(f"{scene}/truth/truth.json"))
reg = truth["registration"]


def load(name):
    pc = o3d.io.read_point_cloud(f"{scene}/clouds/{name}.ply")
    pc.transform(np.array(reg["world_from_" + name]))
    return pc


src, tgt = load(src_name), load(tgt_name)
tgt = tgt.voxel_down_sample(0.05)
tgt.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.4, max_nn=50))
P, Q, N = np.asarray(src.points), np.asarray(tgt.points), np.asarray(tgt.normals)

# The stations (lower spheres) in the world frame; each point's ray from the nearest one.
W = np.array(reg["world_from_" + src_name])
vp = np.loadtxt(f"{scene}/clouds/{src_name.replace('_part', '')}.viewpoints.txt", ndmin=2)
vp = vp @ W[:3, :3].T + W[:3, 3]
V = vp[np.argmin(np.linalg.norm(P[:, None, :] - vp[None, :, :], axis=2), axis=1)]
U = P - V
r = np.linalg.norm(U, axis=1)
U /= r[:, None]
model = truth["clouds"]["spherical_stereo"]
f = model["stereo_width_px"] / (2 * np.pi)
sigma_r = r**2 * model["disparity_sigma_px"] / (f * model["baseline_m"] * np.maximum(np.hypot(U[:, 0], U[:, 1]), 0.2))
print(f"{src_name} -> {tgt_name}: {len(P)} source points, range median {np.median(r):.1f} m, "
      f"model sigma_r median {np.median(sigma_r):.2f} m (10 % {np.percentile(sigma_r, 10):.2f}, 90 % {np.percentile(sigma_r, 90):.2f})")

nns = o3d.core.nns.NearestNeighborSearch(o3d.core.Tensor(Q))
nns.knn_index()


def icp(oracle, k, iters=40):
    T = np.eye(4)
    for _ in range(iters):
        X = P @ T[:3, :3].T + T[:3, 3]
        idx, d2 = nns.knn_search(o3d.core.Tensor(X), 1)
        idx, d = idx.numpy()[:, 0], np.sqrt(d2.numpy()[:, 0])
        n = N[idx]
        res = np.sum(n * (X - Q[idx]), axis=1)
        J = np.hstack([np.cross(X, n), n])
        if oracle:
            cos = np.maximum(np.abs(np.sum(n * (U @ T[:3, :3].T), axis=1)), 0.2)
            m = np.abs(res / cos) < k * sigma_r
            w = 1.0 / (sigma_r[m] ** 2 * cos[m] ** 2)
        else:
            m = d < k
            w = np.ones(m.sum())
        H = J[m].T @ (J[m] * w[:, None])
        xi = -np.linalg.solve(H, J[m].T @ (w * res[m]))
        D = np.eye(4)
        D[:3, :3] = o3d.geometry.get_rotation_matrix_from_axis_angle(xi[:3])
        D[:3, 3] = xi[3:]
        T = D @ T
    X = P @ T[:3, :3].T + T[:3, 3]
    return np.sqrt(np.mean(np.sum((X - P) ** 2, axis=1))), m.mean()


for k in (0.1, 0.2, 0.4, 0.8):
    rms, used = icp(False, k)
    print(f"  plain  DMAX {k:.1f} m:     {rms:.3f} m RMS off, {100 * used:.0f} % of the source used")
for k in (1.0, 2.0, 3.0):
    rms, used = icp(True, k)
    print(f"  oracle K {k:.0f} sigma_r:  {rms:.3f} m RMS off, {100 * used:.0f} % of the source used")
