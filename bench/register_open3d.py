#!/usr/bin/python3
"""Open3D's textbook global registration on one pair, for comparison with mmba
register-cloud: voxel downsampling, normals (radius 2 voxels), FPFH (radius 5 voxels),
RANSAC on feature matches (mutual filter off, edge-length 0.9 + distance checkers),
point-to-plane ICP (Open3D "Global registration" tutorial). Prints target_from_source and the
whole-process wall time (reading included).

usage: register_open3d.py SOURCE TARGET VOXEL_M [--seed N] [--conf FILE.conf]
--conf: also print the error against a Stanford .conf alignment (p_common = R(q)^T p + t,
as bench/register_pair conf=...; the clouds are looked up by file name).
"""
import sys
import time

t0 = time.perf_counter()
import open3d as o3d  # noqa: E402

src_path, tgt_path, voxel = sys.argv[1], sys.argv[2], float(sys.argv[3])
args = sys.argv[4:]
seed = int(args[args.index("--seed") + 1]) if "--seed" in args else 42
conf = args[args.index("--conf") + 1] if "--conf" in args else None
o3d.utility.random.seed(seed)
t_import = time.perf_counter() - t0
t1 = time.perf_counter()
c1 = time.process_time()
src = o3d.io.read_point_cloud(src_path)
tgt = o3d.io.read_point_cloud(tgt_path)


def prep(pc):
    down = pc.voxel_down_sample(voxel)
    down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    fpfh = o3d.pipelines.registration.compute_fpfh_feature(
        down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
    return down, fpfh


sd, sf = prep(src)
td, tf = prep(tgt)
dist = 1.5 * voxel
ransac = o3d.pipelines.registration.registration_ransac_based_on_feature_matching(
    sd, td, sf, tf, True, dist,
    o3d.pipelines.registration.TransformationEstimationPointToPoint(False), 3,
    [o3d.pipelines.registration.CorrespondenceCheckerBasedOnEdgeLength(0.9),
     o3d.pipelines.registration.CorrespondenceCheckerBasedOnDistance(dist)],
    o3d.pipelines.registration.RANSACConvergenceCriteria(100000, 0.999))
src.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
tgt.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
icp = o3d.pipelines.registration.registration_icp(
    src, tgt, 0.4 * voxel, ransac.transformation,
    o3d.pipelines.registration.TransformationEstimationPointToPlane())
wall = time.perf_counter() - t1
cpu = time.process_time() - c1
print(f"open3d {o3d.__version__}: ransac fitness {ransac.fitness:.4f}, icp fitness "
      f"{icp.fitness:.4f}, inlier rmse {icp.inlier_rmse:.6g} m, wall {wall:.3f} s, CPU {cpu:.3f} s "
      f"(+ import {t_import:.2f} s)")
print("target_from_source")
for row in icp.transformation:
    print("  " + " ".join(f"{v:.9f}" for v in row))

if conf:
    import os

    import numpy as np

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from stanford_conf import pose_error, truth  # noqa: E402

    angle, dt = pose_error(np.asarray(icp.transformation), truth(conf, src_path, tgt_path))
    print(f"error vs {conf}: rotation {angle:.4f} deg, translation {1000 * dt:.4f} mm")
