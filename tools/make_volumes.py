#!/usr/bin/env python3
"""Write the small grid volumes of Penumbra's media test scenes (deterministic).

Usage: python3 tools/make_volumes.py

tests/scenes/volumes/smoke.vol: 24^3 voxels, one channel: a soft plume (two
Gaussian blobs along a rising, bending axis) modulated by a fixed sum of
sines, zero at the border, peak density 1. Mitsuba's .vol v3 format (see
crates/scene/src/vol.rs); the header box is the unit cube.

tests/scenes/volumes/sggx.vol: 4^3 voxels, six channels (S_xx, S_yy, S_zz,
S_xy, S_xz, S_yz) for the `sggx` phase function: flakes with normal n and
roughness r, S = n n^T + r^2 (I - n n^T), n turning from +y (x = 0) to +x
(x = 1) and tilting towards z with z, r from 0.1 to 0.6 along y.

tests/scenes/volumes/colors.vol: 4^3 voxels, three channels: a colour
gradient (x red, y green, z blue, in [0.1, 0.9]) for the `volume` texture.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "volumes")


def smoke(n=24):
    vals = []
    for z in range(n):
        for y in range(n):
            for x in range(n):
                p = [(x + 0.5) / n, (y + 0.5) / n, (z + 0.5) / n]
                # Plume axis bends with height.
                cx = 0.5 + 0.15 * math.sin(3.0 * p[1])
                cz = 0.5 - 0.1 * p[1]
                r2 = (p[0] - cx) ** 2 + (p[2] - cz) ** 2
                width = 0.05 + 0.06 * p[1]
                d = math.exp(-r2 / width) * math.exp(-((p[1] - 0.45) ** 2) / 0.12)
                d += 0.6 * math.exp(-((p[0] - 0.35) ** 2 + (p[1] - 0.75) ** 2 + (p[2] - 0.6) ** 2) / 0.01)
                d *= 0.75 + 0.25 * math.sin(11 * p[0] + 7 * p[1]) * math.sin(9 * p[2] + 3 * p[0])
                edge = min(min(p), min(1 - q for q in p))
                d *= min(1.0, edge * n / 2.0)
                vals.append(max(d, 0.0))
    m = max(vals)
    return [v / m for v in vals]


def sggx(n=4):
    vals = []
    for z in range(n):
        for y in range(n):
            for x in range(n):
                p = [(x + 0.5) / n, (y + 0.5) / n, (z + 0.5) / n]
                a = 0.5 * math.pi * p[0]
                t = 0.6 * (p[2] - 0.5)
                nv = [math.sin(a) * math.cos(t), math.cos(a) * math.cos(t), math.sin(t)]
                r2 = (0.1 + 0.5 * p[1]) ** 2
                s = [[nv[i] * nv[j] + r2 * ((i == j) - nv[i] * nv[j]) for j in range(3)] for i in range(3)]
                vals += [s[0][0], s[1][1], s[2][2], s[0][1], s[0][2], s[1][2]]
    return vals


def colors(n=4):
    vals = []
    for z in range(n):
        for y in range(n):
            for x in range(n):
                vals += [0.1 + 0.8 * x / (n - 1), 0.1 + 0.8 * y / (n - 1), 0.1 + 0.8 * z / (n - 1)]
    return vals


def write_vol(path, n, channels, vals):
    with open(path, "wb") as f:
        f.write(b"VOL")
        f.write(bytes([3]))
        f.write(struct.pack("<iiiii", 1, n, n, n, channels))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(struct.pack("<%df" % len(vals), *vals))


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    write_vol(os.path.join(OUT, "smoke.vol"), 24, 1, smoke())
    write_vol(os.path.join(OUT, "sggx.vol"), 4, 6, sggx())
    write_vol(os.path.join(OUT, "colors.vol"), 4, 3, colors())
    print("wrote smoke.vol, sggx.vol and colors.vol in", OUT)
