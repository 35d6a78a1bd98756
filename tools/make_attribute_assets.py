#!/usr/bin/env python3
"""Write the PLY meshes of tests/scenes/vertex_colors.xml (deterministic,
standard library only): Mitsuba mesh attributes for the `mesh_attribute`
texture.

    tests/scenes/attributes/colorball.ply   binary little-endian icosphere
        (320 triangles) with float `red green blue` vertex colours
        (Mitsuba's `vertex_color`) and `ao_x` (a one-component `vertex_ao`)
    tests/scenes/attributes/facetball.ply   ASCII icosphere whose faces carry
        `rough_x` (`face_rough`, one component) and `tint_r tint_g tint_b`
        (`face_tint_color`)
    tests/scenes/attributes/floor.ply       ASCII 8x8 grid of quads split in
        triangles, faces carrying float `r g b` (`face_color`)

Usage: python3 tools/make_attribute_assets.py
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "attributes")


def icosphere(levels=2):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    for _ in range(levels):
        cache, nf = {}, []

        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in p))
                v.append(tuple(c / n for c in p))
                cache[k] = len(v) - 1
            return cache[k]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return v, f


def header(fmt, nv, vprops, nf, fprops):
    h = ["ply", f"format {fmt} 1.0", "comment tools/make_attribute_assets.py", f"element vertex {nv}"]
    h += [f"property {t} {n}" for t, n in vprops]
    h += [f"element face {nf}", "property list uchar int vertex_indices"]
    h += [f"property {t} {n}" for t, n in fprops]
    h.append("end_header")
    return ("\n".join(h) + "\n").encode()


def colorball():
    v, f = icosphere()
    xyz = [("float", "x"), ("float", "y"), ("float", "z")]
    vprops = xyz + [("float", "red"), ("float", "green"), ("float", "blue"), ("float", "ao_x")]
    out = header("binary_little_endian", len(v), vprops, len(f), [])
    for p in v:
        # Hue around the vertical axis, brighter upwards; ao darker below.
        phi = math.atan2(p[2], p[0])
        rgb = [0.5 + 0.45 * math.cos(phi + k * 2 * math.pi / 3) for k in range(3)]
        rgb = [c * (0.55 + 0.45 * p[1]) for c in rgb]
        ao = 0.3 + 0.7 * (0.5 + 0.5 * p[1])
        out += struct.pack("<7f", *p, *rgb, ao)
    for a, b, c in f:
        out += struct.pack("<B3i", 3, a, b, c)
    return out


def facetball():
    v, f = icosphere()
    lines = [header("ascii", len(v), [("float", "x"), ("float", "y"), ("float", "z")], len(f),
                    [("float", "rough_x"), ("float", "tint_r"), ("float", "tint_g"), ("float", "tint_b")])]
    body = [f"{p[0]:.7f} {p[1]:.7f} {p[2]:.7f}" for p in v]
    for i, (a, b, c) in enumerate(f):
        rough = 0.05 + 0.6 * ((i * 37) % 11) / 10
        tint = [0.95, 0.75, 0.45] if i % 3 == 0 else ([0.9, 0.9, 0.92] if i % 3 == 1 else [0.95, 0.6, 0.5])
        body.append(f"3 {a} {b} {c} {rough:.4f} {tint[0]} {tint[1]} {tint[2]}")
    return lines[0] + ("\n".join(body) + "\n").encode()


def floor(n=8):
    v = [(2 * i / n - 1, 0.0, 2 * j / n - 1) for j in range(n + 1) for i in range(n + 1)]
    faces = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i, (j + 1) * (n + 1) + i + 1
            light = (i + j) % 2 == 0
            col = (0.8, 0.8, 0.75) if light else (0.2, 0.35, 0.6)
            # Normals up (+y): counter-clockwise seen from above.
            faces.append(((a, c, b), col))
            faces.append(((b, c, d), tuple(0.7 * x for x in col)))
    lines = [header("ascii", len(v), [("float", "x"), ("float", "y"), ("float", "z")], len(faces),
                    [("float", "r"), ("float", "g"), ("float", "b")])]
    body = [f"{p[0]} {p[1]} {p[2]}" for p in v]
    body += [f"3 {a} {b} {c} {r:.4f} {g:.4f} {bb:.4f}" for (a, b, c), (r, g, bb) in faces]
    return lines[0] + ("\n".join(body) + "\n").encode()


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, data in [("colorball.ply", colorball()), ("facetball.ply", facetball()), ("floor.ply", floor())]:
        with open(os.path.join(OUT, name), "wb") as fh:
            fh.write(data)
        print("wrote", os.path.join(OUT, name), len(data), "bytes")


if __name__ == "__main__":
    main()
