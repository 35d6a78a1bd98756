#!/usr/bin/env python3
"""Write the small textures used by tests/scenes/textured.xml (deterministic,
pure Python, no dependencies):

    tests/scenes/textures/tiles.png    64x64 sRGB colour tiles with thin grout
    tests/scenes/textures/bumps.png    64x64 tangent-space normal map (raw data)
    tests/scenes/textures/dots.png     32x32 greyscale opacity mask (discs)

Usage: python3 tools/make_textures.py
"""
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "textures")


def write_png(path, width, height, channels, rows):
    """rows: list of `height` lists of width*channels ints in 0..255."""
    color_type = {1: 0, 3: 2}[channels]
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def tiles():
    n, rows = 64, []
    palette = [(200, 80, 40), (230, 200, 90), (60, 120, 190), (90, 170, 90)]
    for y in range(n):
        row = []
        for x in range(n):
            tx, ty = x // 16, y // 16
            c = palette[(tx + 2 * ty) % 4]
            if x % 16 == 0 or y % 16 == 0:
                c = (30, 30, 30)
            # a gradient inside each tile, so orientation and filtering show
            f = 0.75 + 0.25 * ((x % 16) / 15.0)
            row += [int(round(v * f)) for v in c]
        rows.append(row)
    return n, n, 3, rows


def bumps():
    # Height h = 0.5 * (sin(2 pi 2 u) + sin(2 pi 2 v)) / (2 pi 2); normal
    # (-dh/du, -dh/dv, 1) normalised, encoded as (n + 1) / 2.
    n, rows = 64, []
    for y in range(n):
        row = []
        for x in range(n):
            u, v = (x + 0.5) / n, (y + 0.5) / n
            dx = 0.6 * math.cos(2 * math.pi * 2 * u)
            dy = 0.6 * math.cos(2 * math.pi * 2 * v)
            nx, ny, nz = -dx, -dy, 1.0
            l = math.sqrt(nx * nx + ny * ny + nz * nz)
            row += [int(round((c / l * 0.5 + 0.5) * 255)) for c in (nx, ny, nz)]
        rows.append(row)
    return n, n, 3, rows


def dots():
    n, rows = 32, []
    for y in range(n):
        row = []
        for x in range(n):
            cx, cy = (x % 16) - 7.5, (y % 16) - 7.5
            row.append(0 if cx * cx + cy * cy < 30 else 255)
        rows.append(row)
    return n, n, 1, rows


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for name, fn in [("tiles", tiles), ("bumps", bumps), ("dots", dots)]:
        w, h, c, rows = fn()
        write_png(os.path.join(OUT, name + ".png"), w, h, c, rows)
        print("wrote", os.path.join(OUT, name + ".png"))
