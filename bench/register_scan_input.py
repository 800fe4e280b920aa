#!/usr/bin/env python3
"""Rebuilds the input of `mmba adjust`'s static-scan feature registration (src/adjust/scans.cc)
for bench/register_pair: every other scan of a simulated project in the world frame by its
delivered world_from_scan (the target), their stations as target viewpoints, the origin as the
source's viewpoint, and the source scan's delivered pose as the reference.

usage: register_scan_input.py PROJECT_DIR SOURCE_SCAN_NUMBER OUT_PREFIX
  reads PROJECT_DIR/project.yaml (lines "- {file: clouds/scans/scan_K.ply, world_from_scan:
  {qvec_wxyz: [w, x, y, z], tvec: [x, y, z]}}") and the binary PLY scans (double x y z, float
  intensity, as `mmba simulate` writes them); writes OUT_PREFIX.ply, OUT_PREFIX.viewpoints.txt,
  OUT_PREFIX.origin.txt and OUT_PREFIX.truth.txt (16 numbers, row-major)."""
import re
import struct
import sys


def rotation(w, x, y, z):
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def read_ply(path):
    data = open(path, 'rb').read()
    end = data.index(b'end_header\n') + len(b'end_header\n')
    header = data[:end].decode().split('\n')
    n = int(next(l for l in header if l.startswith('element vertex')).split()[2])
    props = [l.split()[1:] for l in header if l.startswith('property')]
    if [p[1] for p in props[:3]] != ['x', 'y', 'z'] or props[0][0] != 'double':
        sys.exit('%s: expected double x y z first' % path)
    size = sum({'double': 8, 'float': 4, 'uchar': 1, 'ushort': 2, 'int': 4, 'uint': 4}[p[0]] for p in props)
    return [struct.unpack_from('<ddd', data, end + size * i) for i in range(n)]


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    project, source, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    poses = {}
    pattern = re.compile(r'file: (clouds/scans/scan_(\d+)\.ply), world_from_scan: \{qvec_wxyz: \[([^\]]*)\], tvec: \[([^\]]*)\]')
    for line in open(project + '/project.yaml'):
        m = pattern.search(line)
        if m:
            poses[int(m.group(2))] = (m.group(1), [float(v) for v in m.group(3).split(',')],
                                      [float(v) for v in m.group(4).split(',')])
    if source not in poses or len(poses) < 2:
        sys.exit('%s/project.yaml: no delivered pose of scan_%d or of another scan' % (project, source))
    points = []
    with open(out + '.viewpoints.txt', 'w') as viewpoints:
        for k, (file, q, t) in sorted(poses.items()):
            if k == source:
                continue
            r = rotation(*q)
            for p in read_ply(project + '/' + file):
                points.append([sum(r[i][j] * p[j] for j in range(3)) + t[i] for i in range(3)])
            viewpoints.write('%.9g %.9g %.9g\n' % tuple(t))
    with open(out + '.ply', 'wb') as f:
        f.write(b'ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty double x\n'
                b'property double y\nproperty double z\nend_header\n' % len(points))
        for p in points:
            f.write(struct.pack('<ddd', *p))
    open(out + '.origin.txt', 'w').write('0 0 0\n')
    _, q, t = poses[source]
    r = rotation(*q)
    rows = [r[i] + [t[i]] for i in range(3)] + [[0, 0, 0, 1]]
    open(out + '.truth.txt', 'w').write(' '.join('%.12g' % v for row in rows for v in row) + '\n')
    print('%d target points; source %s' % (len(points), poses[source][0]))


if __name__ == '__main__':
    main()
