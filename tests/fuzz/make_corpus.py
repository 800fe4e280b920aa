#!/usr/bin/env python3
"""Writes the seed corpus of the libFuzzer harnesses: tests/fuzz/corpus/<harness>/.

Seeds are small valid files (so that the fuzzer starts inside each format) and a few broken
ones, copied from the project's own fixtures (tests/data, tests/io_kitti/data) or made here.
Run from anywhere; it replaces the corpus folder. Whole corpus well under 1 MB.
"""
import pathlib
import shutil
import struct

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CORPUS = HERE / "corpus"
SPLIT = b"\n%%MMBA-SPLIT%%\n"  # fuzz::kSplit in fuzz_input.h


def put(harness, name, data):
    folder = CORPUS / harness
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_bytes(data if isinstance(data, bytes) else data.encode())


def copy(harness, path, name=None):
    path = ROOT / path
    put(harness, name or path.name, path.read_bytes())


def bal():
    text = ("2 3 4\n"
            "0 0 -3.8599e+02 3.8712e+02\n1 0 -3.844e+01 4.9212e+02\n"
            "0 1 -6.6792e+02 1.2311e+02\n1 2 1.5e+01 -2.5e+01\n"
            + "0.01\n-0.02\n0.003\n0.1\n-0.2\n-1.5\n400\n-1e-7\n2e-13\n" * 2
            + "0.5\n-0.3\n-4.1\n1.0\n0.2\n-3.9\n-0.7\n0.4\n-5.2\n")
    put("bal", "valid.txt", text)
    put("bal", "truncated.txt", text[: len(text) // 2])
    put("bal", "bad_index.txt", text.replace("1 2 1.5e+01", "1 9 1.5e+01"))
    put("bal", "nan.txt", text.replace("400\n", "nan\n", 1))


def colmap():
    tiny = ROOT / "tests/data/colmap/tiny"
    parts = [(tiny / n).read_bytes() for n in ("cameras.txt", "images.txt", "points3D.txt")]
    put("colmap_text", "tiny", SPLIT.join(parts))
    put("colmap_text", "no_points", SPLIT.join(parts[:2]))
    put("colmap_text", "bad_model", SPLIT.join([parts[0].replace(b"PINHOLE 640", b"PINHOL 640")] + parts[1:]))
    put("colmap_text", "dangling_track", SPLIT.join(parts[:2] + [parts[2].replace(b"1.5 3 2", b"1.5 3 7")]))

    # The same model in COLMAP's binary layout (src/colmap/scene/reconstruction_io.cc).
    cams = struct.pack("<Q", 2)
    cams += struct.pack("<iiQQ4d", 1, 1, 640, 480, 500, 510, 320, 240)  # PINHOLE
    cams += struct.pack("<iiQQ8d", 2, 4, 640, 480, 500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002)  # OPENCV
    images = [
        (1, (1, 0, 0, 0), (0, 0, 0), 1, b"a.jpg", [(320, 240, 1), (400.5, 250.25, 2), (10, 10, -1)]),
        (2, (0.99, 0.01, 0.1, 0.02), (-1, 0, 0.1), 1, b"b.jpg", [(300.5, 230.5, 1), (390, 260, 2)]),
        (3, (0.98, -0.02, -0.19, 0.01), (1, 0.1, 0), 2, b"c.jpg", [(330, 245, 1), (410, 255, 2), (100, 100, 3)]),
    ]
    imgs = struct.pack("<Q", len(images))
    for image_id, q, t, cam, name, pts in images:
        imgs += struct.pack("<I4d3dI", image_id, *q, *t, cam) + name + b"\0" + struct.pack("<Q", len(pts))
        for x, y, pid in pts:
            imgs += struct.pack("<ddq", x, y, pid)
    points = [(1, (0, 0, 10), (255, 0, 0), 0.5, [(1, 0), (2, 0), (3, 0)]),
              (2, (1.5, 0.2, 9.5), (0, 255, 0), 0.25, [(1, 1), (2, 1), (3, 1)]),
              (3, (-3, -2, 12), (10, 20, 30), 1.5, [(3, 2)])]
    pts3d = struct.pack("<Q", len(points))
    for pid, xyz, rgb, err, track in points:
        pts3d += struct.pack("<Q3d3BdQ", pid, *xyz, *rgb, err, len(track))
        for image_id, idx in track:
            pts3d += struct.pack("<II", image_id, idx)
    put("colmap_binary", "tiny", SPLIT.join([cams, imgs, pts3d]))
    put("colmap_binary", "huge_count", SPLIT.join([struct.pack("<Q", 2**62) + cams[8:], imgs, pts3d]))
    put("colmap_binary", "truncated", SPLIT.join([cams, imgs[:60], pts3d]))
    put("colmap_binary", "no_points", SPLIT.join([cams, imgs]))


def survey():
    for name in ("gama-local-subset.gkf", "bad-number.gkf", "datum-defect.gkf", "missing-sigma.gkf",
                 "self-observation.gkf", "unknown-element.gkf", "unknown-point.gkf", "zero-sigma.gkf"):
        copy("gama_local", "tests/data/gama/" + name)
    put("gama_local", "entities.gkf",
        '<?xml version="1.0"?>\n<!DOCTYPE gama-local SYSTEM "gama-local.dtd">\n'
        '<gama-local xmlns="http://www.gnu.org/software/gama/gama-local">\n<network axes-xy="ne" angles="left-handed">\n'
        '<description>&lt;A&amp;B&gt; &#65;&#x42;</description>\n<!-- comment -->\n'
        '<parameters sigma-apr="10" conf-pr="0.95" />\n<points-observations distance-stdev="3 2 1" direction-stdev="10">\n'
        '<point id="A" x="0" y="0" z="0" fix="xyz"/>\n<point id="B" x="100" y="0" adj="xy"/>\n'
        '<point id="C" x="0" y="100" adj="XY"/>\n<obs from="A">\n<direction to="B" val="0" />\n'
        '<direction to="C" val="100-0-0" stdev="5"/>\n<distance to="B" val="100.01"/>\n</obs>\n'
        '<height-differences><dh from="A" to="B" val="0.5" dist="0.1"/></height-differences>\n'
        '<coordinates><point id="B" x="100" y="0"/><cov-mat dim="2" band="0">1 1</cov-mat></coordinates>\n'
        '</points-observations>\n</network>\n</gama-local>\n')
    for name in ("gama-local-subset.csv", "zero-sigma.csv"):
        copy("survey_csv", "tests/data/gama/" + name)
    put("survey_csv", "georeferenced.csv",
        "# a georeferenced network\nparam,sigma-apr,10\nparam,origin,45.5,-73.5,60\nparam,refraction,0.13\n"
        "gpoint,A,45.5,-73.5,60,xyz,\npoint,B,100,0,0,,xyz\npoint,C,0,100,0,,xy\n"
        "set,A\ndirection,A,B,0,10\ndirection,A,C,100-0-0,5\ndistance,A,B,100.01,3\n"
        "s-distance,A,C,100.02,3,1.5,1.6\nz-angle,A,B,99.5,10\nazimuth,A,B,100,20\ndh,A,B,0.5,2\nangle,A,B/C,100,10\n")
    put("survey_csv", "comment_only.csv", "# nothing\n\n")
    put("survey_csv", "duplicate.csv", "point,A,0,0,0,xyz,\npoint,A,1,1,1,xyz,\npoint,B,5,5,5,,xyz\ndistance,A,B,7.07,3\n")


def trajectory():
    rows = "".join("%.1f,%.3f,%.3f,100.0,%.6f,0,0,%.6f\n" % (t, 2 * t, 0.5 * t, 0.995004, 0.099833)
                   for t in (0, 0.5, 1.0, 1.5))
    put("trajectory", "valid.csv", "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n" + rows)
    put("trajectory", "one_row.csv", "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n")
    put("trajectory", "not_increasing.csv",
        "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n1,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n")


def ply():
    head = ("ply\nformat {fmt} 1.0\ncomment seed\nelement vertex 3\nproperty double x\nproperty double y\n"
            "property double z\nproperty float nx\nproperty float ny\nproperty float nz\n"
            "property float intensity\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
            "property double time\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")
    pts = [(1, 2, 3, 0, 0, 1, 0.5, 255, 0, 0, 10.0), (4, 5, 6, 0, 1, 0, 0.25, 0, 255, 0, 10.1),
           (-7, 8.5, 9e5, 1, 0, 0, 1.0, 0, 0, 255, 10.2)]
    ascii_body = "".join(" ".join(str(v) for v in p) + "\n" for p in pts) + "3 0 1 2\n"
    put("ply", "ascii.ply", head.format(fmt="ascii") + ascii_body)
    for fmt, e in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
        body = b"".join(struct.pack(e + "3d4f3Bd", *p) for p in pts) + struct.pack(e + "B3i", 3, 0, 1, 2)
        put("ply", fmt + ".ply", head.format(fmt=fmt).encode() + body)
    xyz_only = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    put("ply", "float_xyz.ply", xyz_only.encode() + struct.pack("<12f", *range(12)))
    put("ply", "truncated.ply", xyz_only.encode() + struct.pack("<5f", *range(5)))
    put("ply", "crlf.ply", "ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty float x\r\nproperty float y\r\n"
        "property float z\r\nend_header\r\n1 2 3\r\n4 nan 6\r\n")


def lzf_literals(data):
    """LZF with literal runs only (valid input for any LZF decoder)."""
    out = b""
    for i in range(0, len(data), 32):
        chunk = data[i:i + 32]
        out += bytes([len(chunk) - 1]) + chunk
    return out


def pcd():
    head = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n"
            "TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA {mode}\n")
    pts = [(1, 2, 3, 0.5), (4, 5, 6, 0.25), (-7, 8.5, 9, 1.0)]
    put("pcd", "ascii.pcd", head.format(mode="ascii") + "".join(" ".join(map(str, p)) + "\n" for p in pts))
    put("pcd", "binary.pcd", head.format(mode="binary").encode() + b"".join(struct.pack("<4f", *p) for p in pts))
    soa = b"".join(struct.pack("<3f", *(p[k] for p in pts)) for k in range(4))
    packed = lzf_literals(soa)
    put("pcd", "binary_compressed.pcd",
        head.format(mode="binary_compressed").encode() + struct.pack("<II", len(packed), len(soa)) + packed)
    rgb = ("VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z rgb\nSIZE 8 8 8 4 4 4 4\nTYPE F F F F F F U\n"
           "COUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n").encode()
    rgb += struct.pack("<3d3fI", 1, 2, 3, 0, 0, 1, 0xff0000) + struct.pack("<3d3fI", 4, 5, 6, 0, 1, 0, 0x00ff00)
    put("pcd", "double_rgb_normals.pcd", rgb)
    put("pcd", "bad_lzf.pcd", head.format(mode="binary_compressed").encode() + struct.pack("<II", 4, 36) + b"\xff\xff\xff\xff")


def xyz():
    put("xyz", "xyz.xyz", "1 2 3\n4 5 6\n-7 8.5 9\n")
    put("xyz", "commas_intensity.xyz", "# x,y,z,i\n1,2,3,0.5\n4,5,6,0.25\n")
    put("xyz", "rgb.xyz", "1 2 3 255 0 0\n4 5 6 0 255 0\n")
    put("xyz", "normals.xyz", "1 2 3 0 0 1\n4 5 6 0 1 0\n")
    put("xyz", "bad.xyz", "1 2 3\n4 five 6\n")


def las():
    def header(minor, fmt, record_length, count, header_size):
        h = bytearray(header_size)
        h[0:4] = b"LASF"
        h[24], h[25] = 1, minor
        struct.pack_into("<HI", h, 94, header_size, header_size)  # header size, offset to points
        struct.pack_into("<I", h, 100, 0)                         # number of VLRs
        h[104] = fmt
        struct.pack_into("<HI", h, 105, record_length, count if minor < 4 or fmt < 6 else 0)
        struct.pack_into("<3d3d", h, 131, 0.001, 0.001, 0.001, 1000.0, 2000.0, 30.0)
        if minor == 4:
            struct.pack_into("<Q", h, 247, count)
        return bytes(h)

    def record(fmt, i):
        r = struct.pack("<3iH", 1000 * i, -2000 * i, 300 + i, 100 * i)
        if fmt < 6:
            r += bytes(4) + struct.pack("<H", 0)                       # flags, class, angle, user, source
            if fmt in (1, 3):
                r += struct.pack("<d", 1e5 + i)
            if fmt in (2, 3):
                r += struct.pack("<3H", 65535, 256 * i, 0)
        else:
            r += bytes(6) + struct.pack("<H", 0) + struct.pack("<d", 1e5 + i)
            if fmt in (7, 8):
                r += struct.pack("<3H", 200, 100, 50)
            if fmt == 8:
                r += struct.pack("<H", 10)
        return r

    for minor, fmt, hsize in ((2, 0, 227), (2, 3, 227), (3, 1, 235), (4, 6, 375), (4, 7, 375), (4, 8, 375)):
        recs = [record(fmt, i) for i in range(3)]
        put("las", "las1%d_fmt%d.las" % (minor, fmt), header(minor, fmt, len(recs[0]), 3, hsize) + b"".join(recs))
    recs = [record(0, i) for i in range(3)]
    put("las", "truncated.las", header(2, 0, len(recs[0]), 3, 227) + b"".join(recs)[:30])
    put("las", "huge_count.las", header(4, 6, 30, 2**40, 375) + bytes(60))


def kitti():
    put("kitti_bin", "four_points.bin", struct.pack("<16f", 1, 2, 0.5, 0.1, 10, -3, -1.7, 0.9,
                                                      50.5, 20.25, 2, 0, -5, 0, 0, 1))
    put("kitti_bin", "nan_point.bin", struct.pack("<8f", 1, 2, 3, 0.5, float("nan"), 0, 0, 0.2))
    put("kitti_bin", "partial_point.bin", struct.pack("<6f", 1, 2, 3, 0.5, 4, 5))
    data = ROOT / "tests/io_kitti/data"
    for path in sorted(data.glob("calib_*.txt")):
        copy("kitti_calib", path.relative_to(ROOT))
    raw = [(data / "raw" / n).read_bytes() for n in ("calib_cam_to_cam.txt", "calib_velo_to_cam.txt")]
    put("kitti_calib", "raw_pair", SPLIT.join(raw))
    put("kitti_calib", "raw_without_velo", (data / "raw_without_velo/calib_cam_to_cam.txt").read_bytes() + SPLIT)
    for path in sorted(data.glob("camera_*.yaml")):
        copy("camera_yaml", path.relative_to(ROOT))
    put("camera_yaml", "rig.yaml",
        "body_from_rig: {qvec_wxyz: [1, 0, 0, 0], tvec: [0.5, 0, 2.1]}\n"
        "rig_from_lidar: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\ncameras:\n"
        "  - {name: cam0, model: OPENCV_FISHEYE, width: 320, height: 400, params: [160, 160, 160, 200, 0.01, 0, 0, 0],\n"
        "     cam_from_rig: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, 0.1]}}\n"
        "  - name: cam1\n    model: PINHOLE\n    width: 320\n    height: 400\n    params: [160, 160, 160, 200]\n"
        "    cam_from_rig: {qvec_wxyz: [0.7071068, 0, 0.7071068, 0], tvec: [0.1, 0, 0]}\n")
    put("camera_yaml", "mount.yaml",
        "body_from_lidar: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, 1.8]}\nbeams: 64\n"
        "elevation_deg: [-24.80, 2.00]\nrotation_hz: 10.00\n")
    put("camera_yaml", "anchors.yaml", "model: &m PINHOLE\nwidth: 10\nheight: *m\nparams: !!binary AAAA\n")


def project():
    head = "mmba_project: 1\nname: seed\norigin: {latitude_deg: 45.5, longitude_deg: -73.5, height_m: 60}\n"
    put("project_yaml", "photos_ts_gnss.yaml", head +
        "check_points: [T3]\nadjustment: {max_iterations: 100, outer_iterations: 2, confidence: 0.95, "
        "outlier_sigma: 4, variance_components: false}\nsensors:\n"
        "  - {id: p, type: photo_collection, images: images, colmap_model: model, calibration: camera.yaml,\n"
        "     control_measurements: control.csv, sigma_px: 0.7, mi_register: [a.jpg], refine: [focal],\n"
        "     loss: {type: cauchy, scale: 2}, gnss_lever_arm_m: [0, -0.1, 0], lidar_scale_range: [0.5, 20]}\n"
        "  - {id: ts, type: total_station, file: network.xml, loss: huber}\n"
        "  - {id: g, type: gnss, file: gnss.csv}\n"
        "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n")
    put("project_yaml", "lidar.yaml", head +
        "sensors:\n  - {id: p, type: photo_collection, images: images, colmap_model: model}\n  - id: l\n    type: lidar_static\n    reference_cloud: lidar.ply\n"
        "    scans:\n      - {file: scan_1.ply, world_from_scan: {qvec_wxyz: [1, 0, 0, 0], tvec: [-15.8, -16.3, 1.5]}}\n"
        "      - {file: scan_1.ply, approximate: true, world_from_scan: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, 0]}}\n"
        "      - {file: scan_1.ply}\n    scans_levelled: true\n    scan_sigma_m: 0.01\n"
        "    range_sigma_m: 0.004\n    max_distance_m: 0.3\n"
        "  - {id: m, type: lidar_mobile, cloud: mobile.ply, trajectory: trajectory.csv, calibration: mount.yaml,\n"
        "     extrinsic: weighted, extrinsic_sigma_m: 0.01, node_spacing_s: 1.0, max_range_m: auto}\n")
    put("project_yaml", "rig_spherical.yaml", head +
        "sensors:\n  - {id: p, type: photo_collection, images: images, colmap_model: model}\n"
        "  - {id: s, type: spherical_stereo, images: images, calibration: spherical.yaml, stations: [S1, S2],\n"
        "     stations_file: stations.csv, observations: observations.csv, tie_block: p, refine: [principal_point]}\n"
        "  - {id: r, type: camera_rig, images: images, calibration: rig.yaml, trajectory: trajectory.csv,\n"
        "     frames_file: frames.csv, observations: observations.csv, tie_block: p, cam_from_rig: weighted,\n"
        "     mi_lidar: mobile, mi_views: cameras}\n"
        "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n"
        "  - {id: m, type: lidar_mobile, cloud: mobile.ply, trajectory: trajectory.csv, calibration: mount.yaml, rig: r}\n")
    put("project_yaml", "unknown_key.yaml", head + "sensors:\n  - {id: p, type: photo_collection, images: images, colour: red}\n")
    put("project_yaml", "duplicate_key.yaml", head + "name: again\nsensors: []\n")
    put("project_yaml", "not_found.yaml", head + "sensors:\n  - {id: g, type: gnss, file: ../x.csv}\n")


def main():
    shutil.rmtree(CORPUS, ignore_errors=True)
    for make in (bal, colmap, survey, trajectory, ply, pcd, xyz, las, kitti, project):
        make()
    total = sum(p.stat().st_size for p in CORPUS.rglob("*") if p.is_file())
    print("corpus: %d files, %d bytes" % (sum(1 for p in CORPUS.rglob("*") if p.is_file()), total))


if __name__ == "__main__":
    main()
