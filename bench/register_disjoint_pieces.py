#!/usr/bin/python3
"""Clouds that do not overlap must be refused: `mmba register-cloud` on two pieces of one real
cloud with a gap between them (bench/RESULTS.md, "Normals retried").

Each of office1, the table scene and the milk carton (PCL's test clouds) is cut along x and
along y into the lowest 40 % and the highest 40 % of its 2–98 % extent (a gap of 20 %); the
source piece is moved by a random rigid transform (seed 5) twice. Prints exit code, status,
the reason, whether the normals retry ran, and the run time. Any "ok" is a wrong one.

Usage (Debian's python3 with numpy and open3d):
  /usr/bin/python3 bench/register_disjoint_pieces.py MMBA [--data DIR] [--work DIR]
"""
import argparse
import json
import os
import subprocess
import tempfile

import numpy as np

import register_real_sweep as S


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument('mmba')
    ap.add_argument('--data', default=os.path.join(here, '..', '..', 'shared', 'data', 'pointclouds', 'pcl_test'))
    ap.add_argument('--work', default='')
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix='disjoint_')
    os.makedirs(work, exist_ok=True)
    rng = np.random.default_rng(5)
    src, tgt, out = (os.path.join(work, n) for n in ('source.xyz', 'target.xyz', 'out.json'))
    wrong = 0
    for name in ['office1.pcd', 'table_scene_mug_stereo_textured.pcd', 'milk.pcd']:
        p = S.load(os.path.join(a.data, name))
        for axis in (0, 1):
            c = p[:, axis]
            lo, hi = np.percentile(c, [2, 98])
            piece_a, piece_b = p[c < lo + 0.4 * (hi - lo)], p[c > lo + 0.6 * (hi - lo)]
            for k in range(2):
                m = np.eye(4)
                m[:3, :3] = S.random_rotation(rng)
                m[:3, 3] = rng.normal(size=3) * 0.5
                np.savetxt(src, piece_a @ m[:3, :3].T + m[:3, 3], fmt='%.6f')
                np.savetxt(tgt, piece_b, fmt='%.6f')
                r = subprocess.run([a.mmba, 'register-cloud', '--source', src, '--target', tgt,
                                    '--output', out, '-q'], capture_output=True)
                d = json.load(open(out))
                retried = any(n.startswith(('retried', 'registered with')) for n in d.get('notes', []))
                wrong += d['status'] == 'ok'
                print(f"{name} axis {axis} move {k}: exit {r.returncode}, {d['status']}, "
                      f"retried {'yes' if retried else 'no'}, {d['runtime_seconds']['total']:.1f} s: "
                      f"{d['reason'][:70]}", flush=True)
    print(f'wrong ok: {wrong}')


if __name__ == '__main__':
    main()
