#!/usr/bin/python3
"""PROJ's own transformations (pyproj) as the reference of tests/apps/adjust_crs_test.cc.

  make DIR CODE LAT LON   a simulated total-station network around (LAT, LON): truth on the
                          CRS's datum, observations (slope distances, directions, zenith angles
                          in each station's own local vertical, with noise), control and
                          approximate coordinates in the CRS computed by pyproj:
                          DIR/network_crs.csv and DIR/project_crs.yaml (crs: CODE, no origin).
  local DIR CODE JSON     the same network in the local tangent plane at the origin that mmba
                          stated in JSON (report.json or adjusted.json), the CRS coordinates of
                          network_crs.csv converted by pyproj: DIR/network_local.csv and
                          DIR/project_local.yaml (origin, no crs).
  compare-adjust DIR CODE OUT_CRS OUT_LOCAL
                          points.csv of both adjustments: the local one's east, north, up
                          converted by pyproj into the CRS against the CRS one's columns; prints
                          "max_difference_m D" and "points N".
  compare-survey DIR CODE OUT_CRS OUT_LOCAL
                          the same for adjusted.json of `mmba survey` (x = east, y = north).
"""
import csv
import json
import math
import os
import random
import sys

from pyproj import CRS, Transformer

IDS = ["A", "B", "C", "D", "E", "F", "G"]
FIXED = {"A", "B", "C"}


def geographic_of(code):
    crs = CRS.from_user_input(code)
    return crs, crs.geodetic_crs


def to_crs(code):
    crs, geo = geographic_of(code)
    return Transformer.from_crs(geo, crs, always_xy=True)


def topocentric(lat, lon, h, ellps):
    """geodetic (lon, lat deg, h) -> ENU at (lat, lon, h) on ellps, and its inverse."""
    pipeline = ("+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
                f"+step +proj=cart +ellps={ellps} "
                f"+step +proj=topocentric +ellps={ellps} +lat_0={lat!r} +lon_0={lon!r} +h_0={h!r}")
    return Transformer.from_pipeline(pipeline)


def make(folder, code, lat0, lon0):
    os.makedirs(folder, exist_ok=True)
    rng = random.Random(58)
    ellps = "GRS80"
    truth = {}
    for k, pid in enumerate(IDS):
        angle = 2 * math.pi * k / len(IDS)
        radius = 600.0 + 150.0 * (k % 3)
        dlat = radius * math.cos(angle) / 111200.0
        dlon = radius * math.sin(angle) / (111200.0 * math.cos(math.radians(lat0)))
        truth[pid] = (lon0 + dlon, lat0 + dlat, 150.0 + 40.0 * math.sin(3 * angle))
    forward = to_crs(code)
    lines = ["param,axes-xy,en", "param,sigma-apr,1"]
    for pid in IDS:
        lon, lat, h = truth[pid]
        e, n, z = forward.transform(lon, lat, h)
        if pid in FIXED:
            lines.append(f"point,{pid},{e:.4f},{n:.4f},{z:.4f},xyz,")
        else:  # approximate coordinates, 0.2-0.4 m off
            lines.append(f"point,{pid},{e + rng.uniform(-0.4, 0.4):.4f},{n + rng.uniform(-0.4, 0.4):.4f},"
                         f"{z + rng.uniform(-0.2, 0.2):.4f},,xyz")
    for station in IDS:
        lon, lat, h = truth[station]
        enu = topocentric(lat, lon, h, ellps)
        lines.append(f"set,{station}")
        for target in IDS:
            if target == station:
                continue
            e, n, u = enu.transform(*truth[target])
            direction = math.degrees(math.atan2(e, n)) % 360.0 / 0.9 + rng.gauss(0, 3e-4)  # gon, 3 cc
            zenith = math.degrees(math.atan2(math.hypot(e, n), u)) / 0.9 + rng.gauss(0, 3e-4)
            distance = math.sqrt(e * e + n * n + u * u) + rng.gauss(0, 0.002)
            lines.append(f"direction,{station},{target},{direction:.6f},3")
            lines.append(f"z-angle,{station},{target},{zenith:.6f},3")
            lines.append(f"s-distance,{station},{target},{distance:.4f},2")
    with open(f"{folder}/network_crs.csv", "w") as out:
        out.write("\n".join(lines) + "\n")
    with open(f"{folder}/project_crs.yaml", "w") as out:
        out.write(f"mmba_project: 1\nname: crs\ncrs: {code}\n"
                  "sensors:\n  - {id: ts, type: total_station, file: network_crs.csv}\n")


def origin_of(json_path):
    with open(json_path) as f:
        data = json.load(f)
    o = data["origin"]
    return o["latitude_deg"], o["longitude_deg"], o["height_m"]


def local(folder, code, json_path):
    lat0, lon0, h0 = origin_of(json_path)
    crs, geo = geographic_of(code)
    inverse = Transformer.from_crs(crs, geo, always_xy=True)
    # mmba's tangent plane without a crs is on WGS84; the coordinates are the same numbers.
    enu = topocentric(lat0, lon0, h0, "WGS84")
    out_lines = ["param,axes-xy,en", f"param,origin,{lat0!r},{lon0!r},{h0!r}"]
    with open(f"{folder}/network_crs.csv") as f:
        for line in f.read().splitlines():
            cells = line.split(",")
            if cells[0] == "param":
                if cells[1] != "axes-xy":
                    out_lines.append(line)
                continue
            if cells[0] == "point":
                lon, lat, h = inverse.transform(float(cells[2]), float(cells[3]), float(cells[4]))
                e, n, u = enu.transform(lon, lat, h)
                cells[2:5] = [f"{e!r}", f"{n!r}", f"{u!r}"]
                out_lines.append(",".join(cells))
                continue
            out_lines.append(line)
    with open(f"{folder}/network_local.csv", "w") as out:
        out.write("\n".join(out_lines) + "\n")
    with open(f"{folder}/project_local.yaml", "w") as out:
        out.write("mmba_project: 1\nname: local\n"
                  f"origin: {{latitude_deg: {lat0!r}, longitude_deg: {lon0!r}, height_m: {h0!r}}}\n"
                  "sensors:\n  - {id: ts, type: total_station, file: network_local.csv}\n")


def local_to_crs(code, json_path):
    lat0, lon0, h0 = origin_of(json_path)
    inverse_enu = topocentric(lat0, lon0, h0, "WGS84")
    forward = to_crs(code)

    def convert(e, n, u):
        lon, lat, h = inverse_enu.transform(e, n, u, direction="INVERSE")
        return forward.transform(lon, lat, h)
    return convert


def report(differences):
    print(f"points {len(differences)}")
    print(f"max_difference_m {max(differences) if differences else float('nan'):.9f}")


def compare_adjust(code, out_crs, out_local):
    convert = local_to_crs(code, f"{out_local}/report.json")
    tag = code.replace("EPSG:", "epsg").replace("+", "_")

    def rows(path):
        with open(path) as f:
            lines = [line for line in f if not line.startswith("#")]
        return {r["id"]: r for r in csv.DictReader(lines)}
    crs_rows, local_rows = rows(f"{out_crs}/points.csv"), rows(f"{out_local}/points.csv")
    differences = []
    for pid, r in local_rows.items():
        reference = convert(float(r["east_m"]), float(r["north_m"]), float(r["up_m"]))
        c = crs_rows[pid]
        got = (float(c[f"easting_{tag}_m"]), float(c[f"northing_{tag}_m"]), float(c[f"height_{tag}_m"]))
        differences.append(math.dist(reference, got))
    report(differences)


def compare_survey(code, out_crs, out_local):
    convert = local_to_crs(code, f"{out_local}/adjusted.json")
    with open(f"{out_crs}/adjusted.json") as f:
        crs_points = {p["id"]: p for p in json.load(f)["points"]}
    with open(f"{out_local}/adjusted.json") as f:
        local_points = json.load(f)["points"]
    differences = []
    for p in local_points:
        reference = convert(p["x"], p["y"], p["z"])
        c = crs_points[p["id"]]
        differences.append(math.dist(reference, (c["x"], c["y"], c["z"])))
    report(differences)


def main(argv):
    mode = argv[1]
    if mode == "make":
        make(argv[2], argv[3], float(argv[4]), float(argv[5]))
    elif mode == "local":
        local(argv[2], argv[3], argv[4])
    elif mode == "compare-adjust":
        compare_adjust(argv[3], argv[4], argv[5])
    elif mode == "compare-survey":
        compare_survey(argv[3], argv[4], argv[5])
    else:
        sys.exit("unknown mode " + mode)


if __name__ == "__main__":
    main(sys.argv)
