#!/usr/bin/python3
"""`mmba register-cloud --scale-range` on a photogrammetric block in a scale of its own.

For each simulated scene (`mmba simulate` output folders), the multi-view cloud is put into
the frame a COLMAP reconstruction without control would have: origin at the centroid of its
cameras (clouds/multi_view.viewpoints.txt), UNITS source units per metre. It is then registered
onto the static LiDAR (clouds/lidar.ply) with `--scale-range MIN MAX` and the default step,
without the camera positions. Reported per scene: the trial scales' outcome (did any trial
register?), the second pass's trials (`from_refinement`), the final status, scale and RMS of
‖T·p − T_true·p‖ over the source, and the wall time.

Usage (Debian's python3 with numpy and open3d):
  /usr/bin/python3 bench/register_scale_search.py MMBA OUTDIR SCENE... [--units 4]
      [--range 0.2 0.3]
"""
import argparse
import json
import os
import subprocess
import time

import numpy as np
import open3d as o3d


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('mmba')
    ap.add_argument('out')
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--units', type=float, default=4.0, help='source units per metre')
    ap.add_argument('--range', type=float, nargs=2, default=[0.2, 0.3])
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    print('| scene | trial scales ok | second pass (scale: status) | status | scale (truth %.4g) | RMS vs truth | time |'
          % (1.0 / args.units))
    print('|---|---|---|---|---|---|---|')
    for scene in args.scenes:
        name = os.path.basename(os.path.normpath(scene))
        cams = np.loadtxt(os.path.join(scene, 'clouds/multi_view.viewpoints.txt')).reshape(-1, 3)
        cloud = o3d.io.read_point_cloud(os.path.join(scene, 'clouds/multi_view.ply'))
        origin = cams.mean(axis=0)
        points = (np.asarray(cloud.points) - origin) * args.units
        cloud.points = o3d.utility.Vector3dVector(points)
        source = os.path.join(args.out, name + '_block.ply')
        o3d.io.write_point_cloud(source, cloud)
        truth = json.load(open(os.path.join(scene, 'truth/truth.json')))['registration']
        world_from_mv = np.array(truth['world_from_multi_view'])
        mv_from_block = np.eye(4)
        mv_from_block[:3, :3] = np.eye(3) / args.units
        mv_from_block[:3, 3] = origin
        t_true = world_from_mv @ mv_from_block
        out = os.path.join(args.out, name + '.json')
        start = time.time()
        run = subprocess.run([args.mmba, 'register-cloud', '--source', source, '--target',
                              os.path.join(scene, 'clouds/lidar.ply'), '--scale-range',
                              str(args.range[0]), str(args.range[1]), '--output', out, '-q'],
                             capture_output=True, text=True)
        seconds = time.time() - start
        if run.returncode not in (0, 3):
            print('| %s | error %d: %s |' % (name, run.returncode, run.stderr.strip()[:200]))
            continue
        result = json.load(open(out))
        attempt = result['target_from_source'] or result.get('failed_attempt_target_from_source')
        t = np.array(attempt if attempt else np.full((4, 4), np.nan)).reshape(4, 4)
        err = (points @ t[:3, :3].T + t[:3, 3]) - (points @ t_true[:3, :3].T + t_true[:3, 3])
        rms = float(np.sqrt((err ** 2).sum(axis=1).mean()))
        first = [x for x in result['trials'] if not x.get('from_refinement')]
        second = [x for x in result['trials'] if x.get('from_refinement')]
        print('| %s | %d of %d | %s | %s | %.5g | %.3g m | %.1f s |' % (
            name, sum(x['status'] == 'ok' for x in first), len(first),
            ', '.join('%.4g: %s' % (x['scale'], x['status'][:40]) for x in second) or '–',
            result['status'], result['scale'], rms, seconds))


if __name__ == '__main__':
    main()
