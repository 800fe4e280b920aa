#!/usr/bin/env python3
"""Summary of bench/mi_panoramas runs: fractions of views < 1 px, wrong "ok" results,
predicted against actual pixel error, and the histograms of the per-view median pixel offset
before and after registration (CSV + SVG, like Wang et al. 2012's histograms).

    bench/mi_panoramas_summary.py OUT_DIR [OUT_DIR ...]

Reads OUT_DIR/runs.csv (written row by row, so a run cut short still counts what it did) and
writes OUT_DIR/summary.md, OUT_DIR/hist_views_{small,large,all}.{csv,svg}.
"""
import csv
import math
import statistics
import sys
from pathlib import Path

BIN_PX = 0.5
BINS = 24


def histogram(values, bin_px=BIN_PX, bins=BINS):
    counts = [0] * bins
    for v in values:
        if math.isfinite(v):
            counts[min(bins - 1, int(v / bin_px))] += 1
    return counts


def write_histogram(base, title, before, after, bin_px=BIN_PX, bins=BINS,
                    unit="px of the image"):
    """Before (red) and after (blue) bars of `before`/`after` in `bins` bins of `bin_px`, the
    last one open: BASE.csv and BASE.svg."""
    BIN_PX, BINS = bin_px, bins  # noqa: N806 (the module defaults, overridden per plot)
    hb, ha = histogram(before, bin_px, bins), histogram(after, bin_px, bins)
    with open(base.with_suffix(".csv"), "w") as out:
        out.write("bin_from_px,bin_to_px,views_before,views_after\n")
        for b in range(BINS):
            top = "inf" if b + 1 == BINS else f"{(b + 1) * BIN_PX:g}"
            out.write(f"{b * BIN_PX:g},{top},{hb[b]},{ha[b]}\n")
    top = max(hb + ha + [1])
    w, h, left, bottom, upper = 720, 360, 60, 50, 40
    pw, ph = w - left - 20, h - upper - bottom
    bar = pw / BINS
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" '
           'font-family="sans-serif" font-size="12">',
           '<rect width="100%" height="100%" fill="white"/>',
           f'<text x="{left}" y="20" font-size="14">{title}</text>']
    for b in range(BINS):
        x = left + b * bar
        for k, (counts, colour) in enumerate(((hb, "#d62728"), (ha, "#1f77b4"))):
            bh = counts[b] / top * ph
            svg.append(f'<rect x="{x + 1 + k * bar / 2:.1f}" y="{upper + ph - bh:.1f}" '
                       f'width="{bar / 2 - 1:.1f}" height="{bh:.1f}" fill="{colour}"/>')
        if b % max(1, BINS // 12) == 0:
            svg.append(f'<text x="{x:.1f}" y="{upper + ph + 15}">{b * BIN_PX:g}</text>')
    svg += [f'<line x1="{left}" y1="{upper + ph}" x2="{left + pw}" y2="{upper + ph}" stroke="black"/>',
            f'<line x1="{left}" y1="{upper}" x2="{left}" y2="{upper + ph}" stroke="black"/>',
            f'<text x="5" y="{upper + 10}">{top} views</text>',
            f'<text x="{left + pw / 2 - 150}" y="{h - 12}">median pixel offset of the view '
            f'({unit}; last bin ≥ {(BINS - 1) * BIN_PX:g})</text>',
            f'<rect x="{w - 200}" y="30" width="12" height="12" fill="#d62728"/>'
            f'<text x="{w - 182}" y="41">before (start)</text>',
            f'<rect x="{w - 200}" y="48" width="12" height="12" fill="#1f77b4"/>'
            f'<text x="{w - 182}" y="59">after (registered)</text>', "</svg>"]
    base.with_suffix(".svg").write_text("\n".join(svg) + "\n")


def summarise(rows, label):
    n = len(rows)
    if n == 0:
        return f"| {label} | 0 | | | | | | | |\n"
    ok = [r for r in rows if r["status"] == "ok"]
    ok_below = [r for r in ok if float(r["image_px_after"]) < 1.0]
    wrong_ok = [r for r in ok if float(r["image_px_after"]) >= 1.0]
    failed_below = [r for r in rows if r["status"] != "ok" and float(r["image_px_after"]) < 1.0]
    all_below = [r for r in rows if float(r["image_px_after"]) < 1.0]
    before = statistics.median(float(r["image_px_before"]) for r in rows)
    after = statistics.median(float(r["image_px_after"]) for r in rows)
    def ratio_text(column):
        ratio = [float(r["image_px_after"]) / float(r[column]) for r in ok
                 if column in r and float(r[column]) > 0]
        return (f"{min(ratio):.1f}–{max(ratio):.1f} (median {statistics.median(ratio):.1f})"
                if ratio else "–")
    ratio = ratio_text("sigma_px")
    if "sigma_px_calibrated" in rows[0]:
        ratio = f"Laplace {ratio}; calibrated {ratio_text('sigma_px_calibrated')}"
    time = statistics.median(float(r["seconds"]) for r in rows)
    cpu = statistics.median(float(r["cpu_seconds"]) for r in rows)
    ok_frac = f"{len(ok_below)}/{len(ok)}" + (f" ({100 * len(ok_below) / len(ok):.0f} %)" if ok else "")
    return (f"| {label} | {n} | {len(ok)} | {ok_frac} | {len(wrong_ok)} | {len(failed_below)} | "
            f"{len(all_below)}/{n} | {before:.2f} → {after:.2f} | {ratio} | "
            f"{time:.0f} s / {cpu:.0f} s |\n")


def main():
    for out_dir in map(Path, sys.argv[1:]):
        with open(out_dir / "runs.csv") as f:
            rows = list(csv.DictReader(f))
        lines = ["| start errors up to | registrations | ok | ok and < 1 px | wrong ok (≥ 1 px) | "
                 "failed but < 1 px | all < 1 px | median offset before → after (px) | "
                 "actual / predicted σ of the ok | median wall / CPU |\n",
                 "|---|---|---|---|---|---|---|---|---|---|\n"]
        for tag, max_m, label in (("small", "0.1", "0.1 m / 1°"), ("large", "0.3", "0.3 m / 2°")):
            subset = [r for r in rows if r["max_m"] == max_m]
            lines.append(summarise(subset, label))
            if subset:
                write_histogram(out_dir / f"hist_views_{tag}",
                                f"{out_dir.name}: start errors up to {label}, {len(subset)} registrations",
                                [float(r["image_px_before"]) for r in subset],
                                [float(r["image_px_after"]) for r in subset])
        for kind in sorted({r["kind"] for r in rows}):
            lines.append(summarise([r for r in rows if r["kind"] == kind], f"all, {kind}"))
        if "sigma_px_calibrated" in rows[0]:
            # Covariance honesty per ok result: actual median offset against the predicted
            # pixel sigma, Laplace and calibrated, and the Mahalanobis² of the 6 parameters'
            # error under the calibrated covariance (expected 6 on average).
            lines += ["\n| view | start | actual median offset | σ Laplace | σ calibrated | "
                      "actual / Laplace | actual / calibrated | factor (halves + restarts) | "
                      "Mahalanobis² (calibrated) |\n", "|---|---|---|---|---|---|---|---|---|\n"]
            for r in rows:
                if r["status"] != "ok":
                    continue
                actual = float(r["image_px_after"])
                sl, sc = float(r["sigma_px"]), float(r["sigma_px_calibrated"])
                lines.append(
                    f"| {r['view']} | {r['max_m']} m / {r['max_deg']}° | {actual:.2f} px | "
                    f"{sl:.3f} px | {sc:.3f} px | {actual / sl:.1f} | {actual / sc:.2f} | "
                    f"{float(r['variance_factor']):.0f} ({float(r['variance_factor_halves']):.0f} + "
                    f"{float(r['variance_factor_restarts']):.0f}) | {float(r['mahalanobis2']):.1f} |\n")
            # The same over every registration (ok or failed): does the calibrated σ track the
            # actual error also where it is large?
            def stats(column):
                ratio = sorted(float(r["image_px_after"]) / float(r[column]) for r in rows
                               if float(r[column]) > 0)
                quart = statistics.quantiles(ratio, n=4) if len(ratio) > 1 else ratio * 3
                return (f"median {statistics.median(ratio):.2f}, quartiles {quart[0]:.2f}–"
                        f"{quart[2]:.2f}, range {ratio[0]:.2f}–{ratio[-1]:.2f}")
            lines.append(f"\nAll {len(rows)} registrations, actual median offset / predicted σ: "
                         f"Laplace {stats('sigma_px')}; calibrated {stats('sigma_px_calibrated')}.\n")
        (out_dir / "summary.md").write_text("".join(lines))
        print(out_dir)
        print("".join(lines))


if __name__ == "__main__":
    main()
