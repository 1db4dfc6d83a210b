#!/usr/bin/env python3
"""Converts an X window dump (xwd, 24/32 bits per pixel TrueColor, as `xwd -root`
writes on Xvfb) to PNG, with Python's own zlib, and says what the picture holds.

    xwd_to_png.py DUMP.xwd OUTPUT.png [--crop X,Y,W,H]
    xwd_to_png.py --stats PICTURE.png

Prints one line of JSON: width, height, `colours` (distinct colours) and `share`,
the share of pixels in each colour class of rviz/relocalizer.rviz (`surface`:
lit, coloured by the normal; `points` and `lines`: the inlier colours;
`background`); render_rviz.sh and the tests judge a render by it.
"""
import json
import struct
import sys
import zlib

BACKGROUND = (24, 24, 32)   # rviz/relocalizer.rviz's Background Color
POINT = (255, 140, 0)       # node_visuals.cpp: point samples
LINE = (0, 220, 255)        # node_visuals.cpp: line samples


def read_xwd(path):
    data = open(path, "rb").read()
    fields = struct.unpack(">25I", data[:100])
    header_size, _, _, _, width, height, _, byte_order = fields[:8]
    bits_per_pixel, bytes_per_line = fields[11], fields[12]
    masks = fields[14:17]
    ncolors = fields[19]
    if bits_per_pixel not in (24, 32) or masks != (0xFF0000, 0xFF00, 0xFF):
        sys.exit(f"xwd_to_png: {path}: need a 24/32-bit TrueColor dump, got {bits_per_pixel} "
                 f"bits per pixel and masks {[hex(m) for m in masks]}")
    start = header_size + 12 * ncolors
    step = bits_per_pixel // 8
    # Least significant byte first (byte_order 0): B, G, R in memory order.
    order = (2, 1, 0) if byte_order == 0 else ((1, 2, 3) if step == 4 else (0, 1, 2))
    rows = []
    for y in range(height):
        line = data[start + y * bytes_per_line:start + y * bytes_per_line + width * step]
        row = bytearray(width * 3)
        for c, offset in enumerate(order):
            row[c::3] = line[offset::step]
        rows.append(bytes(row))
    return width, height, rows


def write_png(path, width, height, rows):
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    raw = b"".join(b"\0" + row for row in rows)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def read_png(path):
    """Only what write_png writes: 8-bit RGB, filter 0."""
    data = open(path, "rb").read()
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height = struct.unpack(">II", body[:8])
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = 1 + 3 * width
    return width, height, [raw[y * stride + 1:(y + 1) * stride] for y in range(height)]


def near(a, b, tolerance=24):
    return all(abs(x - y) <= tolerance for x, y in zip(a, b))


def stats(width, height, rows):
    counts = {}
    for row in rows:
        for x in range(0, len(row), 3):
            pixel = row[x:x + 3]
            counts[pixel] = counts.get(pixel, 0) + 1
    share = {"background": 0, "points": 0, "lines": 0, "surface": 0, "other": 0}
    for pixel, n in counts.items():
        rgb = tuple(pixel)
        if near(rgb, BACKGROUND, 6):
            share["background"] += n
        elif near(rgb, POINT):
            share["points"] += n
        elif near(rgb, LINE):
            share["lines"] += n
        elif max(rgb) - min(rgb) >= 24:  # coloured: the surface; the panels are grey
            share["surface"] += n
        else:
            share["other"] += n
    total = float(width * height)
    return {"width": width, "height": height, "colours": len(counts),
            "share": {k: round(v / total, 4) for k, v in share.items()}}


def main(argv):
    if len(argv) >= 2 and argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0
    if len(argv) == 3 and argv[1] == "--stats":
        print(json.dumps(stats(*read_png(argv[2]))))
        return 0
    if len(argv) not in (3, 5) or (len(argv) == 5 and argv[3] != "--crop"):
        sys.stderr.write(__doc__)
        return 2
    width, height, rows = read_xwd(argv[1])
    if len(argv) == 5:
        x, y, w, h = (int(v) for v in argv[4].split(","))
        rows = [row[3 * x:3 * (x + w)] for row in rows[y:y + h]]
        width, height = w, h
    write_png(argv[2], width, height, rows)
    print(json.dumps(stats(width, height, rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
