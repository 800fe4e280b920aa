#!/usr/bin/env python3
"""An independent LAS 1.4 reader for tests/io_cloud/las_writer_test.cc.

Written from the ASPRS LAS Specification 1.4 R15 alone (public header block Table 3, VLR
header Table 15, Extra Bytes Table 24, point data record formats 6 and 7), with Python's
struct module and none of mmba's code. It checks the rules a LAS 1.4 reader relies on and
prints what the file holds, one item per line, for the C++ test to compare with the cloud it
wrote:

  header <name> <value>            every header field the writer sets
  vlr <user id> <record id> <bytes>
  wkt <text>                       payload of LASF_Projection 2112, NUL removed, line breaks as \n
  extra <name> <type> <description>
  point <x> <y> <z> <intensity> <return byte> <class> <gps time> [<r> <g> <b>] <extra...>

A broken rule exits with status 1 and a message on stderr naming the byte.
Usage: las14_dump.py FILE
"""

import struct
import sys

HEADER = [  # (name, struct format, byte offset) from Table 3
    ("signature", "4s", 0), ("file_source_id", "<H", 4), ("global_encoding", "<H", 6),
    ("version_major", "B", 24), ("version_minor", "B", 25),
    ("system_identifier", "32s", 26), ("generating_software", "32s", 58),
    ("creation_day", "<H", 90), ("creation_year", "<H", 92),
    ("header_size", "<H", 94), ("offset_to_point_data", "<I", 96),
    ("number_of_vlrs", "<I", 100), ("point_format", "B", 104),
    ("record_length", "<H", 105), ("legacy_point_count", "<I", 107),
    ("legacy_by_return", "<5I", 111), ("scale", "<3d", 131), ("offset", "<3d", 155),
    ("max_min", "<6d", 179), ("waveform_start", "<Q", 227), ("first_evlr", "<Q", 235),
    ("number_of_evlrs", "<I", 243), ("point_count", "<Q", 247), ("by_return", "<15Q", 255),
]
BASE_LENGTH = {6: 30, 7: 36}
TYPE_FORMAT = {1: "<B", 2: "<b", 3: "<H", 4: "<h", 5: "<I", 6: "<i", 7: "<Q", 8: "<q",
               9: "<f", 10: "<d"}


def fail(message):
    sys.stderr.write(message + "\n")
    sys.exit(1)


def text(raw):
    return raw.split(b"\0", 1)[0].decode("ascii")


def read_header(data):
    if len(data) < 375:
        fail("file shorter than the 375-byte LAS 1.4 header")
    h = {}
    for name, fmt, at in HEADER:
        value = struct.unpack_from(fmt, data, at)
        h[name] = value[0] if len(value) == 1 else list(value)
    if h["signature"] != b"LASF":
        fail("byte 0: signature is not LASF")
    if (h["version_major"], h["version_minor"]) != (1, 4) or h["header_size"] != 375:
        fail("byte 24/94: not LAS 1.4 with a 375-byte header")
    if h["point_format"] not in BASE_LENGTH:
        fail("byte 104: point format %d is not 6 or 7" % h["point_format"])
    if h["legacy_point_count"] != 0 or any(h["legacy_by_return"]):
        fail("byte 107: legacy counts must be 0 for point formats >= 6")
    if h["global_encoding"] & (1 << 4) == 0:
        fail("byte 6: formats 6-10 must use WKT (global encoding bit 4)")
    return h


def read_vlrs(data, h):
    pos, wkt, extras = h["header_size"], None, []
    for _ in range(h["number_of_vlrs"]):
        if pos + 54 > h["offset_to_point_data"]:
            fail("byte %d: VLR header beyond the point data offset" % pos)
        _, user, record, length, _ = struct.unpack_from("<H16sHH32s", data, pos)
        payload = data[pos + 54:pos + 54 + length]
        print("vlr", text(user), record, length)
        if text(user) == "LASF_Projection" and record == 2112:
            if not payload.endswith(b"\0"):
                fail("byte %d: the WKT is not NUL-terminated" % (pos + 54))
            wkt = text(payload)
            print("wkt", wkt.replace("\n", "\\n"))  # one line: line breaks as \n
        if text(user) == "LASF_Spec" and record == 4:
            if length % 192:
                fail("byte %d: Extra Bytes payload is not a multiple of 192" % (pos + 20))
            for d in range(pos + 54, pos + 54 + length, 192):
                data_type, name, description = data[d + 2], text(data[d + 4:d + 36]), text(data[d + 160:d + 192])
                if data_type not in TYPE_FORMAT:
                    fail("byte %d: extra bytes type %d is not a single number" % (d + 2, data_type))
                extras.append((name, TYPE_FORMAT[data_type]))
                print("extra", name, data_type, description)
        pos += 54 + length
    if pos != h["offset_to_point_data"]:
        fail("byte 96: point data offset %d, the VLRs end at %d" % (h["offset_to_point_data"], pos))
    return extras


def read_points(data, h, extras):
    fmt, length, n = h["point_format"], h["record_length"], h["point_count"]
    if length != BASE_LENGTH[fmt] + sum(struct.calcsize(f) for _, f in extras):
        fail("byte 105: record length %d does not match the format and extra bytes" % length)
    if len(data) != h["offset_to_point_data"] + n * length:
        fail("file size %d, expected %d" % (len(data), h["offset_to_point_data"] + n * length))
    scale, offset, box = h["scale"], h["offset"], h["max_min"]
    for i in range(n):
        r = h["offset_to_point_data"] + i * length
        xyz = [struct.unpack_from("<i", data, r + 4 * k)[0] * scale[k] + offset[k] for k in range(3)]
        for k in range(3):
            if not box[2 * k + 1] - 1e-9 <= xyz[k] <= box[2 * k] + 1e-9:
                fail("point %d: %s outside the header's bounds" % (i, "xyz"[k]))
        intensity, returns, _, classification = struct.unpack_from("<HBBB", data, r + 12)
        gps_time = struct.unpack_from("<d", data, r + 22)[0]
        fields = ["%.17g" % v for v in xyz] + [str(intensity), str(returns), str(classification),
                                                   "%.17g" % gps_time]
        if fmt == 7:
            fields += [str(c) for c in struct.unpack_from("<3H", data, r + 30)]
        at = r + BASE_LENGTH[fmt]
        for _, f in extras:
            fields.append("%.17g" % struct.unpack_from(f, data, at)[0])
            at += struct.calcsize(f)
        print("point", " ".join(fields))
    if h["by_return"][0] != n:
        fail("byte 255: %d first returns for %d points of return 1 of 1" % (h["by_return"][0], n))


def main():
    with open(sys.argv[1], "rb") as f:
        data = f.read()
    h = read_header(data)
    for name in ("global_encoding", "header_size", "offset_to_point_data", "number_of_vlrs",
                 "point_format", "record_length", "point_count", "number_of_evlrs"):
        print("header", name, h[name])
    print("header generating_software", text(h["generating_software"]))
    print("header system_identifier", text(h["system_identifier"]))
    print("header scale", " ".join("%.17g" % v for v in h["scale"]))
    print("header offset", " ".join("%.17g" % v for v in h["offset"]))
    print("header max_min", " ".join("%.17g" % v for v in h["max_min"]))
    read_points(data, h, read_vlrs(data, h))


if __name__ == "__main__":
    main()
