#!/usr/bin/python3
"""PhotoModeler "export" text files of riva2014 -> mmba photo_measurements projects.

Usage (from the repository root; stdlib only):
    /usr/bin/python3 data/dbat/riva2014/convert_pmexport.py

writes data/dbat/riva2014/net1 ... net5, each with images.txt, markpts.txt, camera_nominal.yaml,
control.txt, project.yaml and pm_solution.json.

The export format (blocks separated by one blank line; DBAT's loadpm.m reads the same layout):

  line 1   title
  line 2   tolerance, max. iterations, image width W and height H in pixels
  line 3   default a-priori σ: photo coordinates (px), control points, object points (m),
           camera position x, y, z (m), camera angles (degrees)
  line 4   camera: c, Xp, Yp, Fw, Fh (mm), K1, K2, K3, P1, P2 (PhotoModeler's estimate,
           printed to 4-5 decimals: K2 of the 20 mm lenses prints as -0.00000)
  line 5   the camera's σ as PhotoModeler's defaults (Fw/1000, Fh/1000, 0.5 mm, 0.001, 0.0001,
           ...; the same in all five files): a-priori values, not the adjustment's σ
  photo blocks, 6 lines each, every line starting with the photo number n (0-based):
           n file name
           n X0 Y0 Z0 (m) kappa phi omega (degrees)
           n σ of the six
           (blank: no position covariances)
           n c Xp Yp Fw Fh K1 K2 K3 P1 P2 (the camera of this photo)
           n σ of the ten (line 5 again)
  (blank)  control points: none in these five files (the line is blank)
  object points: id X Y Z σX σY σZ (m, PhotoModeler's adjusted points and σ)
  mark points: photo, id, x, y (px), σx, σy (px; 0 = PhotoModeler's "SmartPoints", automatic
           feature points, whose σ is the default of line 3)
  features and feature visibility (not used here)

Conventions, checked by projecting the object points with PhotoModeler's own camera and
exterior orientation (check_reprojection below; RMS per net in the report it prints):
  - the angles are in the order kappa, phi, omega and R = R1(omega) R2(phi) R3(kappa) takes
    the camera frame (x right, y up, z back) to the object frame, as mmba's omega-phi-kappa
    (docs/formats.md, Photogrammetric camera); the order omega, phi, kappa gives residuals
    over 10^4 px on net1.
  - pixel coordinates: x right, y down, in pixels from the top-left corner of the image,
    written to markpts.txt unchanged. PhotoModeler's calibration of the same 21 images as
    net1 (data/dbat/camcaldemo/photomodeler) matches mmba's with these numbers taken as
    mmba pixels (Xp −0.12 σ, Yp −0.22 σ, docs/photogrammetry.md); half a pixel of offset
    would move Xp and Yp by 0.0016 mm = 1.8 σ. The camera values printed in the exports are
    too coarse to decide this by themselves (with their rounding PhotoModeler's solution
    reprojects with RMS 0.4 px on net1, 0.6 px on net3, 4 px on nets 2 and 4, 12 px on net5).
  - Xp = (1 + b1) xp and Fw = W · pitch · (1 + b1) with pitch = Fh / H (square pixels);
    Yp = yp; K1, K2, K3, P1, P2 as mmba's PHOTOGRAMMETRIC camera.

Point ids: net5 numbers its SmartPoints (σ 0 marks) independently of its targets, and six
ids occur in both. The SmartPoints are the object points after the last decrease of the id
in the object list (their id set equals that of the σ-0 marks, which is checked); they are
given id + 10000. Marks of points without object coordinates are left out (counted).

Control: ctrlpts-2d.txt (the calibration sheet's corners 1001-1004) belongs to nets 1-3,
ctrlpts-3d-1.txt (ids 1-66) to net4, ctrlpts-3d-2.txt (first column the PhotoModeler id; id 0
= a point PhotoModeler did not solve, left out) to net5: found by matching ids and fitting a
similarity to PhotoModeler's points (RMS printed). The files state no σ.
"""
import json
import math
import os
import sys
import textwrap

HERE = os.path.dirname(os.path.abspath(__file__))
SMART_ID_OFFSET = 10000

NETS = [
    # folder, export, control file, control sigma (m; 0 = fixed), why this sigma
    ("net1", "net1-C404Z-2d.txt", "ctrlpts-2d.txt", 0.0, "as PhotoModeler holds them (its points equal the file's)"),
    ("net2", "net2-canon40d-2d.txt", "ctrlpts-2d.txt", 0.0, "as PhotoModeler holds them (its points equal the file's)"),
    ("net3", "net3-canon7d-2d.txt", "ctrlpts-2d.txt", 0.01,
     "PhotoModeler holds them neither: its points differ from them by 1.35 mm RMS after a similarity; "
     "weights this loose place the network without bending it"),
    ("net4", "net4-canon7d-3d.txt", "ctrlpts-3d-1.txt", 0.005,
     "PhotoModeler's points are in a frame of their own (scale 7.74) and differ from them by 1.68 mm RMS "
     "after a similarity; the file states no sigma"),
    ("net5", "net5-canon5d-3d.txt", "ctrlpts-3d-2.txt", 0.05,
     "PhotoModeler's points are in a frame of their own (scale 158) and differ from them by 0.84 m RMS "
     "after a similarity; the file states no sigma"),
]


class FormatError(Exception):
    pass


def numbers(line, where):
    try:
        return [float(v) for v in line.split()]
    except ValueError:
        raise FormatError(f"{where}: expected numbers, got '{line.strip()}'")


def decimals(token):
    """Decimal places of a printed number: 0.00498 -> 5, 3.444e-4 -> 7."""
    mantissa, _, exponent = token.lower().partition("e")
    places = len(mantissa.partition(".")[2])
    return places - int(exponent or 0)


def read_block(lines, i, where):
    """Rows of numbers from line i up to the next blank line; returns (rows, next index)."""
    rows = []
    while i < len(lines) and lines[i].strip():
        rows.append(numbers(lines[i], f"{where} line {i + 1}"))
        i += 1
    return rows, i + 1


def read_photos(lines, name):
    photos, i = [], 5
    while lines[i].strip():
        head = lines[i].split(None, 1)
        rows = [numbers(lines[i + k], f"{name} line {i + k + 1}") for k in (1, 2, 4, 5)]
        if lines[i + 3].strip() or any(int(r[0]) != int(head[0]) for r in rows):
            raise FormatError(f"{name} line {i + 1}: photo block of 6 lines expected")
        photos.append({"n": int(head[0]), "file": head[1].strip(),
                       "eo": rows[0][1:], "eo_sigma": rows[1][1:],
                       "camera": rows[2][1:], "camera_sigma": rows[3][1:]})
        i += 6
    return photos, i + 1


def parse_export(path):
    name = os.path.basename(path)
    lines = open(path, encoding="latin-1").read().split("\n")
    head = numbers(lines[1], f"{name} line 2")
    if len(head) < 4:
        raise FormatError(f"{name} line 2: tolerance, iterations, width, height expected")
    photos, i = read_photos(lines, name)
    control, i = read_block(lines, i, name)
    objects, i = read_block(lines, i, name)
    marks, i = read_block(lines, i, name)
    return {"title": lines[0].strip(), "width": int(head[2]), "height": int(head[3]),
            "default_sigma": numbers(lines[2], name), "camera": numbers(lines[3], name),
            "camera_decimals": [decimals(t) for t in lines[3].split()],
            "camera_sigma": numbers(lines[4], name), "photos": photos,
            "control": control, "objects": objects, "marks": marks}


def renumber_smart_points(pm):
    """Gives the SmartPoints id + SMART_ID_OFFSET when their ids collide with targets'."""
    ids = [int(o[0]) for o in pm["objects"]]
    smart = {int(m[1]) for m in pm["marks"] if m[4] == 0 and m[5] == 0}
    normal = {int(m[1]) for m in pm["marks"] if not (m[4] == 0 and m[5] == 0)}
    if len(set(ids)) == len(ids):
        return 0
    drops = [k for k in range(1, len(ids)) if ids[k] < ids[k - 1]]
    tail = ids[drops[-1]:]
    if set(tail) != smart or len(tail) != len(set(tail)) or not normal:
        raise FormatError("repeated object point ids that are not SmartPoints after targets")
    for o in pm["objects"][drops[-1]:]:
        o[0] += SMART_ID_OFFSET
    for m in pm["marks"]:
        if m[4] == 0 and m[5] == 0:
            m[1] += SMART_ID_OFFSET
    return len(tail)


def rot_opk(omega, phi, kappa):
    """R = R1(omega) R2(phi) R3(kappa), angles in degrees (camera -> object frame)."""
    so, co = math.sin(math.radians(omega)), math.cos(math.radians(omega))
    sp, cp = math.sin(math.radians(phi)), math.cos(math.radians(phi))
    sk, ck = math.sin(math.radians(kappa)), math.cos(math.radians(kappa))
    return [[cp * ck, -cp * sk, sp],
            [co * sk + so * sp * ck, co * ck - so * sp * sk, -so * cp],
            [so * sk - co * sp * ck, so * ck + co * sp * sk, co * cp]]


def camera_terms(pm):
    c, xpp, ypp, fw, fh = pm["camera"][:5]
    pitch = fh / pm["height"]
    b1 = fw / (pm["width"] * pitch) - 1.0
    return {"c": c, "xp": xpp / (1.0 + b1), "yp": ypp, "b1": b1, "pitch": pitch,
            "K1": pm["camera"][5], "K2": pm["camera"][6], "K3": pm["camera"][7],
            "P1": pm["camera"][8], "P2": pm["camera"][9]}


def check_reprojection(pm):
    """RMS (px) of PhotoModeler's marks against its points, EO and printed camera."""
    cam = camera_terms(pm)
    pts = {int(o[0]): o[1:4] for o in pm["objects"]}
    sq, n = 0.0, 0
    for ph in pm["photos"]:
        x0, (kap, phi, omg) = ph["eo"][:3], ph["eo"][3:6]
        r = rot_opk(omg, phi, kap)
        for m in pm["marks"]:
            if int(m[0]) != ph["n"] or int(m[1]) not in pts:
                continue
            d = [pts[int(m[1])][k] - x0[k] for k in range(3)]
            p = [sum(r[k][j] * d[k] for k in range(3)) for j in range(3)]
            xb = (1 + cam["b1"]) * (m[2] * cam["pitch"] - cam["xp"])
            yb = cam["yp"] - m[3] * cam["pitch"]
            r2 = xb * xb + yb * yb
            kr = cam["K1"] * r2 + cam["K2"] * r2 * r2 + cam["K3"] * r2 ** 3
            xc = xb + xb * kr + cam["P1"] * (r2 + 2 * xb * xb) + 2 * cam["P2"] * xb * yb
            yc = yb + yb * kr + cam["P2"] * (r2 + 2 * yb * yb) + 2 * cam["P1"] * xb * yb
            sq += ((xc + cam["c"] * p[0] / p[2]) ** 2 + (yc + cam["c"] * p[1] / p[2]) ** 2)
            n += 1
    return math.sqrt(sq / (2 * n)) / cam["pitch"], n


def read_control(path, known):
    rows = []
    for k, line in enumerate(open(path, encoding="latin-1")):
        if line.startswith("#") or not line.strip():
            continue
        f = [v.strip() for v in line.split(",")]
        if len(f) < 5:
            raise FormatError(f"{path} line {k + 1}: id, name, X, Y, Z expected")
        if int(f[0]) in known:
            rows.append((int(f[0]), f[1], [float(v) for v in f[2:5]]))
    return rows


def similarity_rms(pairs):
    """RMS (m) and scale of the best 7-parameter fit a -> b of point pairs (Horn 1987,
    unit quaternions; stdlib: the 4x4 eigenvector by power iteration on a shifted matrix)."""
    n = len(pairs)
    ma = [sum(p[0][k] for p in pairs) / n for k in range(3)]
    mb = [sum(p[1][k] for p in pairs) / n for k in range(3)]
    a = [[p[0][k] - ma[k] for k in range(3)] for p in pairs]
    b = [[p[1][k] - mb[k] for k in range(3)] for p in pairs]
    s = [[sum(a[i][r] * b[i][c] for i in range(n)) for c in range(3)] for r in range(3)]
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = s
    nm = [[xx + yy + zz, yz - zy, zx - xz, xy - yx],
          [yz - zy, xx - yy - zz, xy + yx, zx + xz],
          [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
          [xy - yx, zx + xz, yz + zy, -xx - yy + zz]]
    shift = sum(abs(v) for row in nm for v in row)
    q = [1.0, 0.1, 0.01, 0.001]
    for _ in range(2000):
        q = [sum((nm[r][c] + (shift if r == c else 0)) * q[c] for c in range(4)) for r in range(4)]
        norm = math.sqrt(sum(v * v for v in q))
        q = [v / norm for v in q]
    w, x, y, z = q
    rot = [[w*w + x*x - y*y - z*z, 2*(x*y - w*z), 2*(x*z + w*y)],
           [2*(x*y + w*z), w*w - x*x + y*y - z*z, 2*(y*z - w*x)],
           [2*(x*z - w*y), 2*(y*z + w*x), w*w - x*x - y*y + z*z]]
    ra = [[sum(rot[r][c] * v[c] for c in range(3)) for r in range(3)] for v in a]
    scale = sum(ra[i][k] * b[i][k] for i in range(n) for k in range(3)) / \
        sum(v * v for p in a for v in p)
    sq = sum((b[i][k] - scale * ra[i][k]) ** 2 for i in range(n) for k in range(3))
    return math.sqrt(sq / n), scale


def write_camera(path, pm, net):
    cam = camera_terms(pm)
    w, h = pm["width"], pm["height"]
    focal = float(round(cam["c"]))
    with open(path, "w") as f:
        f.write(f"# {net}: nominal camera as a user starts a self-calibration: c = PhotoModeler's\n"
                f"# focal length {cam['c']:.4f} mm rounded to whole mm, square pixels of\n"
                f"# pitch Fh / H = {pm['camera'][4]:.5f} / {h} mm, principal point at the format\n"
                "# centre, no distortion (written by convert_pmexport.py).\n")
        f.write("model: PHOTOGRAMMETRIC\n")
        f.write(f"width: {w}\nheight: {h}\n")
        f.write(f"format_width_mm: {w * cam['pitch']:.10g}\n")
        f.write(f"format_height_mm: {pm['camera'][4]:.10g}\n")
        f.write(f"c_mm: {focal:.1f}\n")
        f.write(f"xp_mm: {w * cam['pitch'] / 2:.10g}\nyp_mm: {pm['camera'][4] / 2:.10g}\n")


def write_project(folder, net, sigma_m, n_control, note):
    datum = "held fixed" if sigma_m == 0 else f"weighted at {sigma_m} m per coordinate"
    why = textwrap.wrap(f"{n_control} control points {datum}: {note}.", 92)
    with open(os.path.join(folder, "project.yaml"), "w") as f:
        f.write(f"# riva2014 {net}: PhotoModeler's calibration parameter set (c, Xp, Yp, Fw, K1, K2,\n"
                "# P1, P2; K3 held at 0) self-calibrated from the nominal camera; every mark kept\n"
                "# (no robust loss, no blunder excluded), sigma per mark from the export;\n"
                + "".join(f"# {line}\n" for line in why) +
                "# Written by convert_pmexport.py.\n")
        f.write(f"mmba_project: 1\nname: riva2014_{net}\nframe: cartesian\n")
        f.write("control: {file: control.txt, columns: [id, x, y, z], "
                f"sigma_m: {sigma_m}}}\n")
        f.write("sensors:\n  - id: pm\n    type: photo_measurements\n"
                "    camera: camera_nominal.yaml\n    images: images.txt\n"
                "    measurements:\n      - {file: markpts.txt, columns: [image, id, x, y, sxy]}\n"
                "    refine: [c, xp, yp, K1, K2, P1, P2, b1]\n    loss: none\n")
        f.write("adjustment: {variance_components: false, outlier_sigma: 100}\n")


def write_solution(path, pm, net, export, control_file, fit):
    cam = camera_terms(pm)
    names = ["c", "Xp", "Yp", "Fw", "Fh", "K1", "K2", "K3", "P1", "P2"]
    sol = {
        "source": f"pmexports/{export}",
        "note": "PhotoModeler's bundle solution as printed in the export; camera_apriori_sigma "
                "are the export's camera sigma (PhotoModeler's default a-priori values); "
                "omega, phi, kappa in degrees with R = R1(omega) R2(phi) R3(kappa) camera->object; "
                "point ids of SmartPoints + 10000 where renumbered",
        "width": pm["width"], "height": pm["height"],
        "camera": dict(zip(names, pm["camera"])),
        "camera_decimals": dict(zip(names, pm["camera_decimals"])),
        "camera_apriori_sigma": dict(zip(names, pm["camera_sigma"])),
        "camera_mmba": {k: cam[k] for k in ("c", "xp", "yp", "b1", "K1", "K2", "K3", "P1", "P2")},
        "control_file": control_file,
        "control_fit": {"points": fit[2], "rms_m": fit[0], "scale": fit[1]},
        "images": [{"id": ph["n"], "file": ph["file"],
                    "center": ph["eo"][:3], "omega": ph["eo"][5], "phi": ph["eo"][4],
                    "kappa": ph["eo"][3], "sigma_center": ph["eo_sigma"][:3],
                    "sigma_omega": ph["eo_sigma"][5], "sigma_phi": ph["eo_sigma"][4],
                    "sigma_kappa": ph["eo_sigma"][3]} for ph in pm["photos"]],
        "points": [{"id": int(o[0]), "xyz": o[1:4], "sigma": o[4:7]} for o in pm["objects"]],
    }
    with open(path, "w") as f:  # one image, one point a line
        items = []
        for key, value in sol.items():
            if isinstance(value, list):
                rows = ",\n  ".join(json.dumps(v) for v in value)
                items.append(f"{json.dumps(key)}: [\n  {rows}\n ]")
            else:
                items.append(f"{json.dumps(key)}: {json.dumps(value)}")
        f.write("{\n " + ",\n ".join(items) + "\n}\n")


def convert(net, export, control_file, sigma_m, note):
    pm = parse_export(os.path.join(HERE, "pmexports", export))
    smart = renumber_smart_points(pm)
    folder = os.path.join(HERE, net)
    os.makedirs(folder, exist_ok=True)
    pts = {int(o[0]): o[1:4] for o in pm["objects"]}
    default_sigma = pm["default_sigma"][0]
    kept = [m for m in pm["marks"] if int(m[1]) in pts]
    with open(os.path.join(folder, "images.txt"), "w") as f:
        f.write(f"# {net}: PhotoModeler's photo number, file name (pmexports/{export})\n")
        for ph in pm["photos"]:
            f.write(f"{ph['n']}, {ph['file'].replace(chr(92), '/').split('/')[-1]}\n")
    with open(os.path.join(folder, "markpts.txt"), "w") as f:
        f.write(f"# {net}: photo, point id, x, y (px from the top-left corner, x right, y down),\n"
                f"# sigma (px; the export's, its 0 replaced by the default {default_sigma:g})\n")
        for m in kept:
            s = m[4] if m[4] > 0 else default_sigma
            f.write(f"{int(m[0])}, {int(m[1])}, {m[2]:.4f}, {m[3]:.4f}, {s:g}\n")
    control = read_control(os.path.join(HERE, control_file), pts)
    with open(os.path.join(folder, "control.txt"), "w") as f:
        f.write(f"# {net}: ../{control_file}, the points PhotoModeler solved: id, X, Y, Z (m)\n")
        for cid, _, xyz in control:
            f.write(f"{cid}, {xyz[0]:.5f}, {xyz[1]:.5f}, {xyz[2]:.5f}\n")
    fit = similarity_rms([(pts[cid], xyz) for cid, _, xyz in control]) + (len(control),)
    write_camera(os.path.join(folder, "camera_nominal.yaml"), pm, net)
    write_project(folder, net, sigma_m, len(control), note)
    write_solution(os.path.join(folder, "pm_solution.json"), pm, net, export, control_file, fit)
    rms, n = check_reprojection(pm)
    print(f"{net}: {len(pm['photos'])} photos, {len(pts)} points ({smart} SmartPoints "
          f"renumbered), {len(kept)} marks ({len(pm['marks']) - len(kept)} without a point left "
          f"out), {len(control)} control points of {control_file} (similarity to PM's points: "
          f"RMS {fit[0]:.4f} m, scale {fit[1]:.6g}); PM's printed solution reprojects with "
          f"RMS {rms:.3f} px over {n} marks")


def main():
    try:
        for row in NETS:
            convert(*row)
    except (FormatError, OSError, ValueError) as e:
        print(f"convert_pmexport: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
