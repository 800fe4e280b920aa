#!/usr/bin/python3
"""The normals retry of `mmba register-cloud` on PCL's table scene (bench/RESULTS.md,
"Normals retried").

Cuts table_scene_mug_stereo_textured.pcd along y into two pieces sharing 40 % of the extent
(register_real_sweep.split), keeps every K-th point of each (the target from the second
point), moves the source by the seed-36 sweep's draw 3 (its origin then lies behind the
table) and registers it with `--normal-orientation viewpoint` and `auto`. Prints status,
rotation and translation error against the truth, the reason and the run time.

Usage (Debian's python3 with numpy and open3d):
  /usr/bin/python3 bench/register_normal_retry.py MMBA [--data DIR] [--steps 1,2,3,4] [--work DIR]
"""
import argparse
import json
import os
import re
import subprocess
import tempfile

import numpy as np

import register_real_sweep as S

# The seed-36 sweep's draw 3 of table_ax1_ov0.4 (bench/register_real_sweep.py).
MOVE = np.array([
    [-5.214574355684060691e-01, 8.273718261681045627e-01, 2.086576242404725723e-01, -6.392340605923165775e-01],
    [3.415013812631481072e-01, 4.264610332128904169e-01, -8.375606209381838418e-01, 8.265629226243931260e-01],
    [-7.819584064934557155e-01, -3.654953466382985794e-01, -5.049298982036680705e-01, 2.080130942032248631e-01],
    [0, 0, 0, 1]])


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument('mmba')
    ap.add_argument('--data', default=os.path.join(here, '..', 'data', 'pointclouds', 'pcl_test'))
    ap.add_argument('--steps', default='1,2,3,4')
    ap.add_argument('--work', default='')
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix='normal_retry_')
    os.makedirs(work, exist_ok=True)
    p = S.load(os.path.join(a.data, 'table_scene_mug_stereo_textured.pcd'))
    s_all, t_all = S.split(p, 1, 0.4)
    print('| every k-th point | points (source / target) | `viewpoint` | `auto` | time viewpoint → auto |')
    print('|---|---|---|---|---|')
    for k in [int(x) for x in a.steps.split(',')]:
        s, t = s_all[::k], (t_all[1::k] if k > 1 else t_all)
        src, tgt = os.path.join(work, 'source.xyz'), os.path.join(work, 'target.xyz')
        np.savetxt(src, s @ MOVE[:3, :3].T + MOVE[:3, 3], fmt='%.7f')
        np.savetxt(tgt, t, fmt='%.7f')
        cells, times = [], []
        for mode in ('viewpoint', 'auto'):
            out = os.path.join(work, mode + '.json')
            subprocess.run([a.mmba, 'register-cloud', '--source', src, '--target', tgt,
                            '--normal-orientation', mode, '--output', out, '-q'], capture_output=True)
            d = json.load(open(out))
            attempt = d['target_from_source'] or d.get('failed_attempt_target_from_source')
            e = np.array(attempt if attempt else np.full((4, 4), np.nan)).reshape(4, 4) @ MOVE
            angle = np.degrees(np.arccos(np.clip((np.trace(e[:3, :3]) - 1) / 2, -1, 1)))
            shift = np.linalg.norm(e[:3, 3])
            shift_text = f'{1000 * shift:.3g} mm' if shift < 0.1 else f'{shift:.3g} m'
            cell = f"{d['status']}, {angle:.3g}° / {shift_text}"
            overlap = re.search(r'makes only ([\d.]+)%', d['reason'])
            if overlap:
                cell += f' (overlap {float(overlap.group(1)):.3g} %)'
            elif d['status'] != 'ok':
                cell += ' (' + d['reason'].split(':')[0][:40] + ')'
            cells.append(cell)
            times.append(d['runtime_seconds']['total'])
        print(f'| {k} | {len(s)} / {len(t)} | {cells[0]} | {cells[1]} | {times[0]:.1f} → {times[1]:.1f} s |')


if __name__ == '__main__':
    main()
