#!/usr/bin/python3
"""Prepares the bench/RESULTS.md runs "A photo block without control" from a simulator folder.

  /usr/bin/python3 bench/adjust_no_control.py SIM_DIR [--gnss-sigma 0.02]

writes into SIM_DIR:
  colmap/photos_sim3/      the perturbed COLMAP model moved by a similarity (scale 0.37, a 40°
                           turn about z then 17° about x, a shift of (12, -30, 5) m), as COLMAP
                           delivers a reconstruction: in a frame and scale of its own;
  project_nocontrol.yaml   project.yaml with that model and without control_measurements;
  gnss_cam.csv             gnss.csv plus a `camera` row per photo: its true camera centre
                           (truth/colmap_photos) + N(0, σ) per axis, WGS84;
  project_gnsscam.yaml     project_nocontrol.yaml reading gnss_cam.csv;
  project_lidaronly.yaml   project_nocontrol.yaml with only the photos, the static LiDAR, the
                           total station and GNSS: the LiDAR alone places the block.
Then: mmba adjust SIM_DIR/project_nocontrol.yaml --output OUT (and project_gnsscam.yaml).
"""
import argparse
import math
import os
import re
import shutil

import numpy as np
import yaml


def q2r(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def r2q(m):
    w = math.sqrt(max(0, 1 + m[0, 0] + m[1, 1] + m[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0, 1 + m[0, 0] - m[1, 1] - m[2, 2])) / 2, m[2, 1] - m[1, 2])
    y = math.copysign(math.sqrt(max(0, 1 - m[0, 0] + m[1, 1] - m[2, 2])) / 2, m[0, 2] - m[2, 0])
    z = math.copysign(math.sqrt(max(0, 1 - m[0, 0] - m[1, 1] + m[2, 2])) / 2, m[1, 0] - m[0, 1])
    return [w, x, y, z]


def images(path):
    """(header lines, [(fields of the pose line, points line)])"""
    lines = open(path).read().split('\n')
    out, k = [], 0
    while k < len(lines):
        if lines[k].startswith('#') or not lines[k].strip():
            k += 1
            continue
        out.append((lines[k].split(), lines[k + 1]))
        k += 2
    return [l for l in lines if l.startswith('#')], out


def move_model(src, dst):
    s = 0.37
    a, b = math.radians(40.0), 0.3
    rot = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]) @ \
        np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    t = np.array([12.0, -30.0, 5.0])
    os.makedirs(dst, exist_ok=True)
    shutil.copy(os.path.join(src, 'cameras.txt'), dst)
    header, rows = images(os.path.join(src, 'images.txt'))
    out = header[:]
    for f, points in rows:
        rc = q2r([float(v) for v in f[1:5]])
        tc = np.array([float(v) for v in f[5:8]])
        rn = rc @ rot.T  # cam_from_block' = s·cam_from_world ∘ world_from_block'
        tn = s * tc - rn @ t
        out += [' '.join([f[0]] + ['%.17g' % v for v in r2q(rn)] + ['%.17g' % v for v in tn] + f[8:]), points]
    open(os.path.join(dst, 'images.txt'), 'w').write('\n'.join(out) + '\n')
    out = []
    for line in open(os.path.join(src, 'points3D.txt')).read().split('\n'):
        if line.startswith('#') or not line.strip():
            out.append(line)
            continue
        f = line.split()
        x = s * rot @ np.array([float(v) for v in f[1:4]]) + t
        out.append(' '.join([f[0]] + ['%.17g' % v for v in x] + f[4:]))
    open(os.path.join(dst, 'points3D.txt'), 'w').write('\n'.join(out))


def geodetic_from_enu(enu, lat0, lon0, h0):
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)

    def ecef(lat, lon, h):
        la, lo = math.radians(lat), math.radians(lon)
        n = a / math.sqrt(1 - e2 * math.sin(la) ** 2)
        return np.array([(n + h) * math.cos(la) * math.cos(lo), (n + h) * math.cos(la) * math.sin(lo),
                         (n * (1 - e2) + h) * math.sin(la)])
    la, lo = math.radians(lat0), math.radians(lon0)
    r = np.array([[-math.sin(lo), math.cos(lo), 0],
                  [-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo), math.cos(la)],
                  [math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)]])
    x, y, z = ecef(lat0, lon0, h0) + r.T @ enu
    lon = math.atan2(y, x)
    p = math.hypot(x, y)
    lat = math.atan2(z, p * (1 - e2))
    for _ in range(10):  # Bowring-style fixed point on the latitude
        n = a / math.sqrt(1 - e2 * math.sin(lat) ** 2)
        h = p / math.cos(lat) - n
        lat = math.atan2(z, p * (1 - e2 * n / (n + h)))
    n = a / math.sqrt(1 - e2 * math.sin(lat) ** 2)
    return math.degrees(lat), math.degrees(lon), p / math.cos(lat) - n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('sim')
    ap.add_argument('--gnss-sigma', type=float, default=0.02)
    args = ap.parse_args()
    sim = args.sim
    move_model(os.path.join(sim, 'colmap', 'photos'), os.path.join(sim, 'colmap', 'photos_sim3'))
    project = open(os.path.join(sim, 'project.yaml')).read()
    origin = re.search(r'origin: \{latitude_deg: ([-0-9.]+), longitude_deg: ([-0-9.]+), height_m: ([-0-9.]+)\}', project)
    lat0, lon0, h0 = (float(v) for v in origin.groups())
    nocontrol = re.sub(r'\n *control_measurements:[^\n]*', '', project)
    nocontrol = nocontrol.replace('colmap_model: colmap/photos', 'colmap_model: colmap/photos_sim3')
    open(os.path.join(sim, 'project_nocontrol.yaml'), 'w').write(nocontrol)
    rng = np.random.default_rng(3)
    rows = []
    for f, _ in images(os.path.join(sim, 'truth', 'colmap_photos', 'images.txt'))[1]:
        centre = -q2r([float(v) for v in f[1:5]]).T @ np.array([float(v) for v in f[5:8]])
        lat, lon, h = geodetic_from_enu(centre + rng.normal(size=3) * args.gnss_sigma, lat0, lon0, h0)
        s = args.gnss_sigma
        rows.append(f'{f[9]},camera,,{lat:.10f},{lon:.10f},{h:.4f},{s},{s},{s * 1.5}')
    gnss = open(os.path.join(sim, 'gnss.csv')).read().rstrip('\n')
    open(os.path.join(sim, 'gnss_cam.csv'), 'w').write(gnss + '\n' + '\n'.join(rows) + '\n')
    open(os.path.join(sim, 'project_gnsscam.yaml'), 'w').write(nocontrol.replace('file: gnss.csv', 'file: gnss_cam.csv'))
    # Only the photos and the static LiDAR (with the total station and GNSS for the datum and
    # the check points): nothing that sees the photos' tie points, so the LiDAR alone places them.
    lidar_only = yaml.safe_load(nocontrol)
    lidar_only['sensors'] = [x for x in lidar_only['sensors']
                             if x['type'] in ('photo_collection', 'lidar_static', 'total_station', 'gnss')]
    with open(os.path.join(sim, 'project_lidaronly.yaml'), 'w') as out:
        yaml.safe_dump(lidar_only, out, sort_keys=False)
    print(f'{sim}: colmap/photos_sim3, project_nocontrol.yaml, gnss_cam.csv ({len(rows)} camera rows), project_gnsscam.yaml, '
          'project_lidaronly.yaml')


if __name__ == '__main__':
    main()
