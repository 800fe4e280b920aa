#!/usr/bin/python3
"""Virtual range scans of the Stanford bunny for every view of `bun.conf`.

Only bun000 and bun045 of the ten Stanford bunny scans are in ../shared/data; the Stanford range
scans registered pairwise to their bun.conf alignment are wanted on all of them. This
module renders the other views from the zipper reconstruction (`bun_zipper_res2.ply`, in
bun000's frame), so that the default `mmba register-cloud` can be tried on the pairs with less
overlap (90° apart, the top, chin and ear views) without the real scans.

A scan: parallel rays (the Cyberware 3030's linear sweep) along the view direction
R(q)ᵀ·(0, 0, −1) of the scan's bun.conf pose (p_common = R(q)ᵀ p + t; bun000 looks along −z),
0.6 mm apart (the real scans' spacing), the nearest triangle per ray (z-buffer), surfaces seen
more obliquely than 78° dropped (as a triangulation scanner loses them), Gaussian range noise
(0.1 mm by default) along the ray, then the points moved into the scan's own frame
p = R(q)(p_common − t). Checked against the real bun045: the virtual bun045 and the real one
cover each other to 97.5 % / 97.7 % within 1 mm.

The mesh is the half-resolution reconstruction (8,171 vertices, edges ~1.5–2 mm), so the
virtual scans are faceted where the real ones are smooth: a proxy for the overlap and the
views, not for the scanner's noise or edge artefacts.
"""
import numpy as np
import open3d as o3d


def read_conf(path):
    """{name: (R(q), t)} of bun.conf; p_common = R(q)ᵀ p + t."""
    conf = {}
    for line in open(path):
        f = line.split()
        if len(f) == 9 and f[0] == 'bmesh':
            t = np.array([float(v) for v in f[2:5]])
            qx, qy, qz, qw = [float(v) for v in f[5:9]]
            r = o3d.geometry.get_rotation_matrix_from_quaternion([qw, qx, qy, qz])
            conf[f[1].rsplit('.', 1)[0]] = (r, t)
    return conf


def render(vertices, faces, direction, step=0.0006, min_cos=0.2):
    """Nearest surface points along parallel rays `direction`, `step` apart (common frame)."""
    d = np.asarray(direction, float)
    d /= np.linalg.norm(d)
    u = np.cross(d, [0.0, 1.0, 0.0])
    if np.linalg.norm(u) < 1e-6:
        u = np.cross(d, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    p = np.stack([vertices @ u, vertices @ v, vertices @ d], 1)
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                 vertices[faces[:, 2]] - vertices[faces[:, 0]])
    cos_ray = np.abs(n @ d) / (np.linalg.norm(n, axis=1) + 1e-30)
    lo = p[:, :2].min(0)
    w, h = ((p[:, :2].max(0) - lo) / step).astype(int) + 2
    depth = np.full((h, w), np.inf)
    cos_at = np.zeros((h, w))
    for face, c in zip(faces, cos_ray):
        a, b, e = p[face]
        x0, y0 = np.floor((np.minimum(np.minimum(a[:2], b[:2]), e[:2]) - lo) / step).astype(int)
        x1, y1 = np.ceil((np.maximum(np.maximum(a[:2], b[:2]), e[:2]) - lo) / step).astype(int)
        xs, ys = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1))
        px, py = lo[0] + xs * step, lo[1] + ys * step
        det = (b[0] - a[0]) * (e[1] - a[1]) - (e[0] - a[0]) * (b[1] - a[1])
        if abs(det) < 1e-18:
            continue
        l1 = ((px - a[0]) * (e[1] - a[1]) - (e[0] - a[0]) * (py - a[1])) / det
        l2 = ((b[0] - a[0]) * (py - a[1]) - (px - a[0]) * (b[1] - a[1])) / det
        inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        if not inside.any():
            continue
        z = (a[2] + l1 * (b[2] - a[2]) + l2 * (e[2] - a[2]))[inside]
        yy, xx = ys[inside], xs[inside]
        nearer = z < depth[yy, xx]
        depth[yy[nearer], xx[nearer]] = z[nearer]
        cos_at[yy[nearer], xx[nearer]] = c
    ys, xs = np.nonzero(np.isfinite(depth) & (cos_at > min_cos))
    return (np.outer(lo[0] + xs * step, u) + np.outer(lo[1] + ys * step, v) +
            np.outer(depth[ys, xs], d)), d


def virtual_scan(mesh_path, conf, name, rng, noise=0.0001, step=0.0006):
    """The virtual scan `name` of bun.conf in its own frame."""
    mesh = o3d.io.read_triangle_mesh(mesh_path)
    r, t = conf[name]
    points, d = render(np.asarray(mesh.vertices), np.asarray(mesh.triangles),
                       r.T @ np.array([0.0, 0.0, -1.0]), step)
    points = points + np.outer(rng.normal(scale=noise, size=len(points)), d)
    return (points - t) @ r.T


def main():
    import argparse
    import os
    import shutil
    ap = argparse.ArgumentParser(description='write virtual Stanford bunny scans named as '
                                 'bun.conf names them (the real bun000/bun045 copied)')
    ap.add_argument('outdir')
    ap.add_argument('--data', default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                   '..', '..', 'shared', 'data', 'pointclouds',
                                                   'stanford_bunny'))
    ap.add_argument('--noise', type=float, default=0.0001, help='range noise σ, m')
    ap.add_argument('--seed', type=int, default=1)
    args = ap.parse_args()
    os.makedirs(args.outdir, exist_ok=True)
    conf = read_conf(os.path.join(args.data, 'bun.conf'))
    shutil.copy(os.path.join(args.data, 'bun.conf'), args.outdir)
    rng = np.random.default_rng(args.seed)
    for name in conf:
        out = os.path.join(args.outdir, name + '.ply')
        real = os.path.join(args.data, name + '.ply')
        if os.path.exists(real):
            shutil.copy(real, out)
            print(f'{name}: real scan copied')
            continue
        points = virtual_scan(os.path.join(args.data, 'bun_zipper_res2.ply'), conf, name, rng,
                              args.noise)
        o3d.io.write_point_cloud(out, o3d.geometry.PointCloud(
            o3d.utility.Vector3dVector(points)), write_ascii=False)
        print(f'{name}: {len(points)} virtual points')


if __name__ == '__main__':
    main()
