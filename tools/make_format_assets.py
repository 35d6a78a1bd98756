#!/usr/bin/env python3
"""Write the assets of tests/scenes/format_*.xml (deterministic, no
dependencies beyond the standard library):

    tests/scenes/format/twomeshes.serialized   Mitsuba's serialized mesh format,
        version 4, two meshes: index 0 a tetrahedron (positions only), index 1
        a 16x8 uv-sphere-like "pebble" with normals and uvs (single precision)
    tests/scenes/format/warm.spd                an emission spectrum, two columns
    tests/scenes/format/teal.spd                a reflectance spectrum

Usage: python3 tools/make_format_assets.py
"""
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "format")

HAS_NORMALS, HAS_TEXCOORDS, SINGLE = 0x0001, 0x0002, 0x1000


def mesh_blob(name, positions, faces, normals=None, uvs=None):
    flags = SINGLE | (HAS_NORMALS if normals else 0) | (HAS_TEXCOORDS if uvs else 0)
    body = struct.pack("<I", flags) + name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions), len(faces))
    body += b"".join(struct.pack("<3f", *p) for p in positions)
    if normals:
        body += b"".join(struct.pack("<3f", *n) for n in normals)
    if uvs:
        body += b"".join(struct.pack("<2f", *t) for t in uvs)
    body += b"".join(struct.pack("<3I", *f) for f in faces)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body, 9)


def tetrahedron():
    p = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
    p = [tuple(c * 0.5 for c in v) for v in p]
    f = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
    return p, f


def pebble(nu=16, nv=8):
    pos, nrm, uv, faces = [], [], [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append((0.5 * n[0], 0.35 * n[1], 0.5 * n[2]))
            nrm.append(n)
            uv.append((i / nu, j / nv))
    w = nu + 1
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = j * w + i, j * w + i + 1, (j + 1) * w + i, (j + 1) * w + i + 1
            if j > 0:
                faces.append((a, b, c))
            if j < nv - 1:
                faces.append((b, d, c))
    return pos, nrm, uv, faces


def main():
    os.makedirs(OUT, exist_ok=True)
    tp, tf = tetrahedron()
    pp, pn, pu, pf = pebble()
    blobs = [mesh_blob("tetra", tp, tf), mesh_blob("pebble", pp, pf, pn, pu)]
    data, offsets = b"", []
    for b in blobs:
        offsets.append(len(data))
        data += b
    data += b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(blobs))
    with open(os.path.join(OUT, "twomeshes.serialized"), "wb") as f:
        f.write(data)
    with open(os.path.join(OUT, "warm.spd"), "w") as f:
        f.write("# wavelength(nm) value: a warm emission spectrum\n")
        for wl in range(360, 831, 10):
            f.write(f"{wl} {0.4 + 1.2 * (wl - 360) / 470:.4f}\n")
    with open(os.path.join(OUT, "teal.spd"), "w") as f:
        f.write("# a teal reflectance\n")
        for wl in range(380, 781, 20):
            f.write(f"{wl} {0.1 + 0.6 * math.exp(-((wl - 500) / 45.0) ** 2):.4f}\n")
    print("wrote", OUT)


if __name__ == "__main__":
    main()
