#!/usr/bin/python3
"""How far an MI rig calibration inside `mmba adjust` (mi_register, mi_lidar: mobile) is from
the simulator's truth.

Reads SIM/truth/truth.json (true rig_from_lidar = body_from_rig⁻¹ · body_from_lidar),
SIM/calib/ladybug.yaml (the rig's OPENCV_FISHEYE cameras and cam_from_rig) and
OUT/mi/rig_calibration.json (register-mi's result: cam_from_lidar = rig_from_lidar, and its
start). Prints, for the start and the result, the LiDAR centre's distance and the rotation
angle from the truth, and the pixel offset of points at 5–15 m within 60° of each camera's
axis projected with the estimate against the truth (median and 90th percentile over all
cameras).

Usage: /usr/bin/python3 bench/mi_rig_calibration_truth.py SIM OUT
"""
import json
import sys

import numpy as np
import yaml


def rotation(q_wxyz):
    w, x, y, z = q_wxyz
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def fisheye(camera, x):
    """OPENCV_FISHEYE projection (COLMAP's model) of camera-frame points x (N×3)."""
    fx, fy, cx, cy, k1, k2, k3, k4 = camera['params']
    r = np.linalg.norm(x[:, :2], axis=1)
    theta = np.arctan2(r, x[:, 2])
    theta_d = theta * (1 + k1 * theta**2 + k2 * theta**4 + k3 * theta**6 + k4 * theta**8)
    scale = np.where(r > 1e-12, theta_d / np.maximum(r, 1e-12), 1.0)
    return np.stack([fx * x[:, 0] * scale + cx, fy * x[:, 1] * scale + cy], 1)


def main():
    sim, out = sys.argv[1], sys.argv[2]
    truth = json.load(open(sim + '/truth/truth.json'))
    true = np.linalg.inv(np.array(truth['rig']['body_from_rig']['matrix'])) @ \
        np.array(truth['lidar']['mobile']['body_from_lidar']['matrix'])
    result = json.load(open(out + '/mi/rig_calibration.json'))
    cameras = yaml.safe_load(open(sim + '/calib/ladybug.yaml'))['cameras']
    print('status', result['status'], result.get('reason', ''))
    rng = np.random.default_rng(1)
    # A failed calibration holds no pose (cam_from_lidar null); its end is the failed attempt.
    end = 'cam_from_lidar' if result['status'] == 'ok' else 'failed_attempt_cam_from_lidar'
    for key in ('cam_from_lidar_start', end):
        if result.get(key) is None:
            print(key, 'null')
            continue
        estimate = np.array(result[key])
        d = np.linalg.inv(true) @ estimate
        angle = np.degrees(np.arccos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1)))
        shift = np.linalg.norm(estimate[:3, 3] - true[:3, 3])
        offsets = []
        for camera in cameras:
            cam_from_rig = np.eye(4)
            cam_from_rig[:3, :3] = rotation(camera['cam_from_rig']['qvec_wxyz'])
            cam_from_rig[:3, 3] = camera['cam_from_rig']['tvec']
            f, c = camera['params'][:2], camera['params'][2:4]
            u = rng.uniform([0, 0], [camera['width'], camera['height']], (2000, 2))
            rays = np.c_[(u - c) / f, np.ones(len(u))]
            rays = rays[np.degrees(np.arctan(np.linalg.norm(rays[:, :2], axis=1))) < 60]
            in_cam = rays / np.linalg.norm(rays, axis=1, keepdims=True) * rng.uniform(5, 15, (len(rays), 1))
            in_lidar = np.linalg.inv(cam_from_rig @ true) @ np.c_[in_cam, np.ones(len(in_cam))].T
            a = fisheye(camera, (cam_from_rig @ true @ in_lidar).T[:, :3])
            b = fisheye(camera, (cam_from_rig @ estimate @ in_lidar).T[:, :3])
            offsets.append(np.linalg.norm(a - b, axis=1))
        offsets = np.concatenate(offsets)
        print('%-21s %.1f mm, %.3f deg from the truth; pixel offset median %.2f px, p90 %.2f px' %
              (key, shift * 1e3, angle, np.median(offsets), np.percentile(offsets, 90)))


if __name__ == '__main__':
    main()
