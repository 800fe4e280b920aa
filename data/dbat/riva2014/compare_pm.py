#!/usr/bin/python3
"""mmba's adjustment of a riva2014 network against PhotoModeler's solution in its export.

Usage: /usr/bin/python3 data/dbat/riva2014/compare_pm.py data/dbat/riva2014/netN OUTPUT_DIR

OUTPUT_DIR is that of `mmba adjust .../netN/project.yaml --output OUTPUT_DIR`. Prints σ0, the
camera in PhotoModeler's terms (Xp = (1 + b1) xp, Fw = W · pitch · (1 + b1)) with the
difference Δ = mmba − PM over mmba's σ and over half the last digit PM printed (the export's
camera σ are PhotoModeler's a-priori defaults, not the adjustment's), the points and the
projection centres after the similarity that takes PM's points onto mmba's (PhotoModeler's
3-D networks are in a frame of their own scale), and the control: RMS of the control file
against mmba's points and against PM's points after their similarity. stdlib only.
"""
import csv
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from convert_pmexport import similarity_rms  # noqa: E402


def similarity(pairs):
    """(scale, R, ta, tb): b ≈ scale · R (a − ta) + tb, Horn's quaternion solution."""
    rms, scale = similarity_rms(pairs)
    n = len(pairs)
    ma = [sum(p[0][k] for p in pairs) / n for k in range(3)]
    mb = [sum(p[1][k] for p in pairs) / n for k in range(3)]
    # The rotation again from the centred cross-covariance by SVD-free polar iteration.
    m = [[sum((p[1][r] - mb[r]) * (p[0][c] - ma[c]) for p in pairs) for c in range(3)] for r in range(3)]
    for _ in range(100):  # R <- (R + R^-T) / 2 converges to the polar factor
        det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
               + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
        cof = [[(m[(r + 1) % 3][(c + 1) % 3] * m[(r + 2) % 3][(c + 2) % 3]
                 - m[(r + 1) % 3][(c + 2) % 3] * m[(r + 2) % 3][(c + 1) % 3]) / det for c in range(3)]
               for r in range(3)]
        m = [[(m[r][c] + cof[r][c]) / 2 for c in range(3)] for r in range(3)]
    return scale, m, ma, mb, rms


def apply(sim, x):
    scale, rot, ma, mb, _ = sim
    d = [x[k] - ma[k] for k in range(3)]
    return [scale * sum(rot[r][c] * d[c] for c in range(3)) + mb[r] for r in range(3)]


def rms3(diffs):
    return math.sqrt(sum(sum(v * v for v in d) for d in diffs) / len(diffs)) if diffs else float("nan")


def camera_rows(pm, report):
    cam = {p["name"]: p for p in report["photo_measurements"]["camera"]}
    w = pm["width"]
    b1, sb1 = cam["b1"]["adjusted"], cam["b1"]["sigma"]
    pitch = cam["pixel_width_mm"]["adjusted"]
    mm = {"c": (cam["c"]["adjusted"], cam["c"]["sigma"]),
          "Xp": ((1 + b1) * cam["xp"]["adjusted"], (1 + b1) * cam["xp"]["sigma"]),
          "Yp": (cam["yp"]["adjusted"], cam["yp"]["sigma"]),
          "Fw": (w * pitch * (1 + b1), w * pitch * sb1),
          "K1": (cam["K1"]["adjusted"], cam["K1"]["sigma"]), "K2": (cam["K2"]["adjusted"], cam["K2"]["sigma"]),
          "P1": (cam["P1"]["adjusted"], cam["P1"]["sigma"]), "P2": (cam["P2"]["adjusted"], cam["P2"]["sigma"])}
    rows = []
    for name, (value, sigma) in mm.items():
        printed = pm["camera"][name]
        half_digit = 0.5 * 10 ** -pm["camera_decimals"][name]
        delta = value - printed
        rows.append((name, printed, value, sigma, delta, delta / sigma if sigma else float("nan"),
                     delta / half_digit))
    return rows


def main(net_dir, out_dir):
    pm = json.load(open(os.path.join(net_dir, "pm_solution.json")))
    report = json.load(open(os.path.join(out_dir, "report.json")))
    pts = {}
    with open(os.path.join(out_dir, "pm_points.csv")) as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            pts[row["point"]] = ([float(row[k]) for k in ("x_m", "y_m", "z_m")], row["kind"])
    imgs = {}
    with open(os.path.join(out_dir, "pm_images.csv")) as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            imgs[row["image"]] = [float(row[k]) for k in ("x_m", "y_m", "z_m")]
    s0 = report["sigma0"]["aposteriori"]
    print(f"sigma0 {s0:.3f}, dof {report['sigma0']['dof']}; images {len(imgs)} of {len(pm['images'])}, "
          f"points {len(pts)} of {len(pm['points'])}")
    print("| parameter | PhotoModeler (printed) | mmba ± σ | Δ | Δ/σ_mmba | Δ / half last digit |")
    print("|---|---|---|---|---|---|")
    for name, printed, value, sigma, delta, dsig, ddig in camera_rows(pm, report):
        print(f"| {name} | {printed:g} | {value:.6g} ± {sigma:.2g} | {delta:+.3g} | {dsig:+.2f} | {ddig:+.2f} |")
    pairs = [(p["xyz"], pts[str(p["id"])][0]) for p in pm["points"] if str(p["id"]) in pts]
    sim = similarity(pairs)
    diffs = [[apply(sim, a)[k] - b[k] for k in range(3)] for a, b in pairs]
    sig = sorted(sim[0] * math.sqrt(sum(v * v for v in p["sigma"]) / 3) for p in pm["points"])
    print(f"points: {len(pairs)} common, similarity PM -> mmba scale {sim[0]:.6f}, RMS 3-D difference "
          f"{rms3(diffs) * 1000:.3f} mm (PM's median point sigma, scaled: {sig[len(sig) // 2] * 1000:.3f} mm)")
    cen = [(apply(sim, i["center"]), imgs[str(i["id"])]) for i in pm["images"] if str(i["id"]) in imgs]
    print(f"projection centres: RMS 3-D difference {rms3([[a[k] - b[k] for k in range(3)] for a, b in cen]) * 1000:.3f} mm")
    control = {}
    for line in open(os.path.join(net_dir, "control.txt")):
        if not line.startswith("#") and line.strip():
            f = [v.strip() for v in line.split(",")]
            control[f[0]] = [float(v) for v in f[1:4]]
    on = [[pts[i][0][k] - x[k] for k in range(3)] for i, x in control.items() if i in pts]
    print(f"control: mmba points - control RMS {rms3(on) * 1000:.3f} mm over {len(on)}; "
          f"PM's points onto control by a similarity RMS {pm['control_fit']['rms_m'] * 1000:.3f} mm "
          f"(scale {pm['control_fit']['scale']:.6g})")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
