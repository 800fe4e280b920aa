"""The ground truth of a Stanford pair from its .conf file, and the error of an estimate.

A .conf line `bmesh NAME tx ty tz qx qy qz qw` places scan NAME in the common frame:
p_common = R(q)^T p + t (as bench/register_pair conf=...). The truth of target_from_source is
common_from(target)^-1 · common_from(source); the error is the rotation angle of
estimate · truth^-1 and the distance between their translations (where each puts the
source frame's origin)."""
import os
import sys

import numpy as np


def common_from_scan(conf, name):
    for line in open(conf):
        f = line.split()
        if len(f) == 9 and f[0] == "bmesh" and f[1] == name:
            t = np.array([float(v) for v in f[2:5]])
            qx, qy, qz, qw = (float(v) for v in f[5:9])
            n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
            r = np.array([
                [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
            m = np.eye(4)
            m[:3, :3] = r.T
            m[:3, 3] = t
            return m
    sys.exit(f"{conf} has no line for {name}")


def truth(conf, source_path, target_path):
    return np.linalg.inv(common_from_scan(conf, os.path.basename(target_path))) @ common_from_scan(
        conf, os.path.basename(source_path))


def pose_error(estimate, true):
    """(rotation in degrees, translation in metres)."""
    dr = estimate[:3, :3] @ true[:3, :3].T
    angle = np.degrees(np.arccos(np.clip((np.trace(dr) - 1) / 2, -1, 1)))
    return angle, np.linalg.norm(estimate[:3, 3] - true[:3, 3])
