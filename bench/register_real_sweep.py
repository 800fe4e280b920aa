#!/usr/bin/python3
"""Robustness sweep of `mmba register-cloud` on real clouds with a known answer.

Each case cuts two overlapping pieces out of one real cloud (or takes two real scans with a
known alignment), moves the source by a random rigid transform (any rotation, a shift of the
order of the cloud's extent), runs `mmba register-cloud` with its default settings and
compares the result with the truth: RMS of ||T·p − T_true·p|| over the source. A case is
"right" when that RMS is below `--right-spacings` × the source's point spacing, else
"wrong". A "wrong ok" is the failure that must not happen; "failed" is an honest refusal.

Usage (Debian's python3 with numpy and open3d, for reading PCD/PLY and writing PLY):
  /usr/bin/python3 bench/register_real_sweep.py MMBA OUTDIR [--draws N] [--seed S]
      [--cases office1,table,milk,bunny_mm,v090_bun045,v180_v090,...] [--data DIR]
      [--overlaps 0:0.5,1:0.4] [--noise-spacings K] [--source-keep F] [--outliers F]
(vNAME = a virtual scan of bun.conf's view NAME rendered from the zipper mesh:
stanford_virtual_scans.py)
Writes OUTDIR/sweep.csv (one row per registration) and prints a summary table.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import time

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def load(path):
    cloud = o3d.io.read_point_cloud(path, remove_nan_points=True, remove_infinite_points=True)
    return np.asarray(cloud.points, dtype=np.float64)


def spacing(points):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    d = np.asarray(cloud.compute_nearest_neighbor_distance())
    return float(np.median(d))


def write_ply(path, points):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    o3d.io.write_point_cloud(path, cloud, write_ascii=False)


def split(points, axis, overlap):
    """Two pieces along `axis` that share `overlap` of the extent around the median."""
    c = points[:, axis]
    lo, hi = np.percentile(c, 1), np.percentile(c, 99)
    mid = np.median(c)
    half = 0.5 * overlap * (hi - lo)
    return points[c <= mid + half], points[c >= mid - half]


def stanford_conf(conf_path):
    """{file name: 4×4 common_from_scan} of a Stanford .conf (p_common = R(q)ᵀ p + t)."""
    import stanford_virtual_scans as vs
    poses = {}
    for name, (r, t) in vs.read_conf(conf_path).items():
        m = np.eye(4)
        m[:3, :3] = r.T
        m[:3, 3] = t
        poses[name + '.ply'] = m
    return poses


def make_cases(data, names, rng, overlaps=((0, 0.5), (1, 0.4)), noise_spacings=0.0,
               source_keep=0.7, outliers=0.0):
    """(name, source points, target points, target_from_source before the random move).
    noise_spacings > 0: each piece of a cut cloud gets independent isotropic Gaussian noise of
    that many times the cloud's median point spacing, so that the two pieces share no point
    exactly (as two scans of one surface do not). source_keep: the fraction of the source piece
    kept (the target keeps 0.7; a smaller value gives a sparser source, as a photogrammetric
    cloud against a scan). outliers > 0: that fraction of each piece's count added as uniform
    points in the piece's bounding box (a dense matcher's blunders)."""
    pcl = os.path.join(data, 'pcl_test')
    bunny = os.path.join(data, 'stanford_bunny')
    out = []
    for name in names:
        if name in ('office1', 'table', 'milk', 'pclbunny'):
            file = {'office1': 'office1.pcd', 'table': 'table_scene_mug_stereo_textured.pcd',
                    'milk': 'milk.pcd', 'pclbunny': 'bunny.pcd'}[name]
            p = load(os.path.join(pcl, file))
            sigma = noise_spacings * spacing(p)
            for axis, overlap in overlaps:
                s, t = split(p, axis, overlap)
                # different samplings, as two scans of one surface have
                s = s[rng.random(len(s)) < source_keep]
                t = t[rng.random(len(t)) < 0.7]
                if sigma > 0:
                    s = s + rng.normal(scale=sigma, size=s.shape)
                    t = t + rng.normal(scale=sigma, size=t.shape)
                if outliers > 0:
                    s, t = (np.vstack([c, rng.uniform(c.min(0), c.max(0),
                                                      size=(int(outliers * len(c)), 3))])
                            for c in (s, t))
                tag = f'_n{noise_spacings:g}' if sigma > 0 else ''
                tag += f'_k{source_keep:g}' if source_keep != 0.7 else ''
                tag += f'_o{outliers:g}' if outliers > 0 else ''
                out.append((f'{name}_ax{axis}_ov{overlap}{tag}', s, t, np.eye(4)))
        elif name.startswith('bun') or name.startswith('zipper'):
            # SOURCE_TARGET[_mm] of the Stanford scans, aligned by bun.conf (the zipper
            # reconstruction is in bun000's frame)
            conf = stanford_conf(os.path.join(bunny, 'bun.conf'))
            conf['zipper'] = conf['bun000.ply']
            parts = name.split('_')
            files = {'bun000': 'bun000.ply', 'bun045': 'bun045.ply', 'zipper': 'bun_zipper_res2.ply'}
            s = load(os.path.join(bunny, files[parts[0]]))
            t = load(os.path.join(bunny, files[parts[1]]))
            key = lambda n: 'zipper' if n == 'zipper' else files[n]
            truth = np.linalg.inv(conf[key(parts[1])]) @ conf[key(parts[0])]
            if name.endswith('_mm'):
                s, t = s * 1000.0, t * 1000.0
                truth = truth.copy()
                truth[:3, 3] *= 1000.0
            out.append((name, s, t, truth))
        elif name == 'kitti':
            # a Velodyne HDL-64 scan (ring pattern, density falling with range): two azimuth
            # sectors of 200° sharing 100°, each keeping a random 70 % of its points
            scan = np.fromfile(os.path.join(data, '..', 'kitti', 'velodyne', '000000.bin'),
                               dtype=np.float32).reshape(-1, 4)[:, :3].astype(np.float64)
            az = np.degrees(np.arctan2(scan[:, 1], scan[:, 0]))
            s = scan[(az > -150) & (az < 50)]
            t = scan[(az > -50) & (az < 150)]
            s = s[rng.random(len(s)) < 0.7]
            t = t[rng.random(len(t)) < 0.7]
            # independent range noise (the HDL-64's ~2 cm), so that no point is shared exactly
            for c in (s, t):
                c *= (1.0 + rng.normal(scale=0.015, size=len(c)) /
                      np.maximum(np.linalg.norm(c, axis=1), 1e-9))[:, None]
            out.append((name, s, t, np.eye(4)))
        elif name.startswith('v') and '_' in name:
            # vSOURCE_TARGET: virtual scans of the Stanford views that are not in the data
            # (stanford_virtual_scans.py) against a virtual or a real (bun000/bun045) scan
            import stanford_virtual_scans as vs
            conf = vs.read_conf(os.path.join(bunny, 'bun.conf'))
            mesh = os.path.join(bunny, 'bun_zipper_res2.ply')
            src_name, tgt_name = name[1:].rsplit('_', 1)

            def scan(n):
                if n.startswith('v'):
                    return vs.virtual_scan(mesh, conf, n[1:], rng)
                return load(os.path.join(bunny, n + '.ply'))
            s, t = scan('v' + src_name), scan(tgt_name)
            poses = stanford_conf(os.path.join(bunny, 'bun.conf'))
            pose = lambda n: poses[n.lstrip('v') + '.ply']
            truth = np.linalg.inv(pose(tgt_name)) @ pose(src_name)
            out.append((name, s, t, truth))
        else:
            sys.exit(f'unknown case {name}')
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('mmba')
    ap.add_argument('outdir')
    ap.add_argument('--draws', type=int, default=3)
    ap.add_argument('--seed', type=int, default=2026)
    ap.add_argument('--cases', default='office1,table,milk,pclbunny,bun045_bun000,bun045_bun000_mm')
    ap.add_argument('--data', default=os.path.join(os.path.dirname(__file__), '..', '..',
                                                   'shared', 'data', 'pointclouds'))
    ap.add_argument('--right-spacings', type=float, default=2.0)
    ap.add_argument('--offset', default='', help='X,Y,Z added to both clouds (e.g. UTM '
                    'coordinates 500000,5000000,100)')
    ap.add_argument('--extra', default='', help='extra register-cloud arguments')
    ap.add_argument('--noise-spacings', type=float, default=0.0,
                    help='independent Gaussian noise on each piece of office1/table/milk/'
                    'pclbunny, in median point spacings (default 0: the pieces share points)')
    ap.add_argument('--source-keep', type=float, default=0.7,
                    help='fraction of the source piece kept (the target keeps 0.7)')
    ap.add_argument('--outliers', type=float, default=0.0,
                    help='uniform outliers added to each piece, as a fraction of its points')
    ap.add_argument('--overlaps', default='0:0.5,1:0.4',
                    help='the pieces of office1/table/milk/pclbunny: AXIS:SHARED,... (SHARED = '
                    'the fraction of the extent both pieces hold; each piece holds (1+SHARED)/2)')
    args = ap.parse_args()
    os.makedirs(args.outdir, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    rows = []
    for name, src, tgt, base_truth in make_cases(
            args.data, args.cases.split(','), rng,
            [(int(a), float(o)) for a, o in (x.split(':') for x in args.overlaps.split(','))],
            args.noise_spacings, args.source_keep, args.outliers):
        s_spacing = spacing(src)
        extent = float(np.linalg.norm(np.ptp(src, axis=0)))
        target_path = os.path.join(args.outdir, f'{name}_target.ply')
        offset = np.array([float(v) for v in args.offset.split(',')]) if args.offset else np.zeros(3)
        write_ply(target_path, tgt + offset)
        for k in range(args.draws):
            move = np.eye(4)
            move[:3, :3] = random_rotation(rng) if k > 0 else np.eye(3)
            move[:3, 3] = rng.normal(size=3) * 0.5 * extent if k > 0 else 0.0
            moved = src @ move[:3, :3].T + move[:3, 3]
            truth = base_truth @ np.linalg.inv(move)
            if args.offset:
                # both clouds in far-off coordinates (a map grid): T' = T(+o)·T·T(−o)
                shift = np.eye(4)
                shift[:3, 3] = offset
                truth = shift @ truth @ np.linalg.inv(shift)
                moved = moved + offset
            source_path = os.path.join(args.outdir, f'{name}_{k}_source.ply')
            write_ply(source_path, moved)
            out_json = os.path.join(args.outdir, f'{name}_{k}.json')
            t0 = time.time()
            r = subprocess.run([args.mmba, 'register-cloud', '--source', source_path,
                                '--target', target_path, '--output', out_json, '--quiet'] +
                               args.extra.split(), capture_output=True, text=True)
            wall = time.time() - t0
            if r.returncode == 2 or not os.path.exists(out_json):
                rows.append(dict(case=name, draw=k, status='input-error', rms_m=float('nan'),
                                 spacing_m=s_spacing, verdict='error', wall_s=wall,
                                 reason=r.stderr.strip()[:200]))
                continue
            res = json.load(open(out_json))
            # a failed result's transform is its best attempt, kept apart (null when there was none)
            attempt = res['target_from_source'] or res.get('failed_attempt_target_from_source')
            est = np.array(attempt if attempt else np.full((4, 4), np.nan), dtype=np.float64).reshape(4, 4)
            rms = float(np.sqrt(np.mean(np.sum(
                (moved @ (est[:3, :3] - truth[:3, :3]).T + (est[:3, 3] - truth[:3, 3])) ** 2,
                axis=1))))
            right = rms < args.right_spacings * s_spacing
            status = res['status']
            verdict = ('right ok' if right else 'WRONG OK') if status == 'ok' else (
                'failed (was right)' if right else 'failed')
            rows.append(dict(case=name, draw=k, status=status, rms_m=rms, spacing_m=s_spacing,
                             verdict=verdict, wall_s=wall, reason=res.get('reason', '')[:200]))
            print(f'{name:28s} draw {k}: {status:7s} rms {rms:.4g} m (spacing {s_spacing:.3g}) '
                  f'{verdict:18s} {wall:5.1f} s  {res.get("reason", "")[:90]}', flush=True)
    with open(os.path.join(args.outdir, 'sweep.csv'), 'w', newline='') as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    counts = {}
    for row in rows:
        counts[row['verdict']] = counts.get(row['verdict'], 0) + 1
    print('summary:', ', '.join(f'{k} {v}' for k, v in sorted(counts.items())))


if __name__ == '__main__':
    main()
