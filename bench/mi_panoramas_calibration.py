#!/usr/bin/env python3
"""Covariance honesty of bench/mi_panoramas runs, from their logs (stdout).

    bench/mi_panoramas_calibration.py LOG [LOG ...]

Per log and over all: registrations, ok, right ok (whole-panorama median offset < 1 px),
wrong ok (>= 1 px), the worst ok with its calibrated sigmas, and for the ok results the actual
whole-panorama median offset against
  * sigma_px_calibrated (the views' points, the views' factor: bench/mi_panoramas_summary.py's
    "actual / calibrated"),
  * the whole-panorama sigma of the reported covariance (the image's Laplace sigma times
    sqrt(covariance_factor), covariance_factor = max(views' factor, whole-image factor) as
    RegisterFrames computes it; for a log whose covariance used the views' factor only, the
    same formula gives the covariance with both factors),
and the Mahalanobis² of the 6 parameters' error under the reported covariance (as printed;
chi²(6): median 5.35, mean 6), the median CPU per registration.
"""
import re
import statistics
import sys

ROW = re.compile(
    r"\] (\S+)\s+(\S+)\s+(\S+)\s+image\s+([\d.]+) ->\s+([\d.]+) px\s+views\s+([\d.]+) ->\s+"
    r"([\d.]+) px\s+sigma ([-\d.]+) px \(calibrated ([-\d.]+), factor ([-\d.]+)\).*maha2 (\S+)"
    r".*\(cpu ([\d.]+)\)")
IMAGE = re.compile(r"image checks: sigma ([-\d.]+) px, restarts ([-\d.]+) px, halves ([-\d.]+) "
                   r"px, factor ([-\d.]+), calibrated sigma ([-\d.]+) px")


def parse(path):
    rows, current = [], None
    for line in open(path):
        m = ROW.search(line)
        if m:
            current = dict(view=m[1], size=m[2], status=m[3], after=float(m[5]),
                           sigma=float(m[8]), sigma_cal=float(m[9]), factor=float(m[10]),
                           maha2=float(m[11]) if m[11] not in ("nan", "-nan") else float("nan"),
                           cpu=float(m[12]), image_sigma=None, image_factor=None,
                           image_sigma_cal=None)
            rows.append(current)
            continue
        m = IMAGE.search(line)
        if m and current is not None:
            current.update(image_sigma=float(m[1]), image_factor=float(m[4]),
                           image_sigma_cal=float(m[5]))
    return rows


def median_text(values):
    values = sorted(v for v in values if v == v)
    if not values:
        return "–"
    return f"{statistics.median(values):.2f} ({values[0]:.2f}–{values[-1]:.2f})"


def summary(label, rows):
    ok = [r for r in rows if r["status"] == "ok"]
    right = [r for r in ok if r["after"] < 1.0]
    wrong = [r for r in ok if r["after"] >= 1.0]
    worst = max(ok, key=lambda r: r["after"], default=None)
    worst_text = "–"
    if worst is not None:
        worst_text = (f"{worst['view']} {worst['size']} {worst['after']:.2f} px (σ cal. "
                      f"{worst['sigma_cal']:.3f}, whole image {worst['image_sigma_cal']} px)")
    by_views = [r["after"] / r["sigma_cal"] for r in ok if r["sigma_cal"] > 0]
    whole = []
    for r in ok:
        if r["image_sigma"] is not None and r["image_sigma"] > 0:
            factor = max(r["factor"], r["image_factor"])
            whole.append(r["after"] / (r["image_sigma"] * factor ** 0.5))
    fraction = f"{100 * len(right) / len(ok):.1f} %" if ok else "–"
    cpu = statistics.median(r["cpu"] for r in rows) if rows else float("nan")
    return (f"| {label} | {len(rows)} | {len(ok)} | {len(right)} | {len(wrong)} | {fraction} | "
            f"{worst_text} | {median_text(by_views)} | {median_text(whole)} | "
            f"{median_text([r['maha2'] for r in ok])} | {cpu:.1f} s |")


def main():
    print("| log | registrations | ok | right (< 1 px) | wrong (≥ 1 px) | right / ok | worst ok | "
          "actual / σ calibrated (views) | actual / σ of the covariance (whole image) | "
          "Mahalanobis² | median CPU |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    everything = []
    for path in sys.argv[1:]:
        rows = parse(path)
        everything += rows
        print(summary(path, rows))
    if len(sys.argv) > 2:
        print(summary("all", everything))


if __name__ == "__main__":
    main()
