#!/usr/bin/env python3
"""Write the small data files of Penumbra's shape test scenes (deterministic).

Usage: python3 tools/make_shape_assets.py

tests/scenes/shapes/ellipsoids.ply: five ellipsoids in the layout Mitsuba
    3.9.1's `ellipsoids` and `ellipsoidsmesh` read (binary little-endian,
    float32): x y z, nx ny nz, one extra column `opacities`, scale_0..2
    (natural log of the radii before `extent`), rot_0..3 (the quaternion,
    real part first). Two of them overlap, so rays leave one surface from
    inside the other (both plugins cull back faces).
tests/scenes/shapes/torus.sdf.vol: a 20^3 grid (Mitsuba's .vol v3, one
    channel) of signed distances, in the grid's [0,1]^3 object space, to a
    tilted torus joined with a sphere (negative inside), for `sdfgrid`.
tests/scenes/shapes/curves.txt: control points (x y z radius per line, an
    empty line between curves) of a tapering helix, a zigzag whose radius
    jumps between points, and a single segment, for `linearcurve`.
tests/scenes/shapes/bspline.txt: the same helix and zigzag, and a curve of
    four points whose end radii are zero, for `bsplinecurve`.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "shapes")


def quat(axis, angle_deg):
    """(r, i, j, k) of a rotation by `angle_deg` about `axis`."""
    n = math.sqrt(sum(a * a for a in axis))
    h = math.radians(angle_deg) / 2
    s = math.sin(h) / n
    return (math.cos(h), axis[0] * s, axis[1] * s, axis[2] * s)


# (center, radii after the default extent 3, rotation)
ELLIPSOIDS = [
    ((-0.55, 0.30, 0.10), (0.45, 0.30, 0.25), quat((0, 1, 0), 30)),
    ((-0.05, 0.35, 0.25), (0.20, 0.35, 0.20), quat((1, 0, 1), 40)),
    ((0.55, 0.25, -0.10), (0.25, 0.25, 0.25), quat((0, 0, 1), 0)),
    ((0.25, 0.15, 0.55), (0.30, 0.12, 0.18), quat((0, 1, 0), -50)),
    ((-0.30, 0.70, -0.35), (0.18, 0.18, 0.40), quat((1, 0.3, 0), 70)),
]


def write_ellipsoids(path):
    names = ["x", "y", "z", "nx", "ny", "nz", "opacities",
             "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % len(ELLIPSOIDS)
    header += "".join("property float %s\n" % n for n in names) + "end_header\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        for c, r, q in ELLIPSOIDS:
            row = list(c) + [0.0, 0.0, 0.0, 0.9] + [math.log(x / 3.0) for x in r] + list(q)
            f.write(struct.pack("<%df" % len(row), *row))


def sdf_torus_sphere(p):
    """Signed distance to a torus (R 0.28, r 0.1) tilted 30 degrees about x,
    centred at (0.5, 0.45, 0.5), joined with a sphere (r 0.16) at (0.62, 0.62, 0.45)."""
    x, y, z = p[0] - 0.5, p[1] - 0.45, p[2] - 0.5
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    y, z = c * y - s * z, s * y + c * z
    q = math.hypot(x, z) - 0.28
    torus = math.hypot(q, y) - 0.1
    sphere = math.dist(p, (0.62, 0.62, 0.45)) - 0.16
    return min(torus, sphere)


def write_sdf(path, n=20):
    vals = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                vals.append(sdf_torus_sphere((i / (n - 1), j / (n - 1), k / (n - 1))))
    with open(path, "wb") as f:
        f.write(b"VOL")
        f.write(bytes([3]))
        f.write(struct.pack("<iiiii", 1, n, n, n, 1))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(struct.pack("<%df" % len(vals), *vals))


def curves():
    helix = []
    for k in range(24):
        a = k * 0.45
        helix.append((0.25 * math.cos(a) - 0.45, 0.15 + 0.035 * k, 0.25 * math.sin(a) - 0.2,
                      0.06 - 0.0017 * k))
    zigzag = [(-0.1 + 0.16 * k, 0.12 + 0.1 * (k % 2), 0.35 - 0.05 * k, [0.12, 0.03, 0.1, 0.05, 0.09, 0.04][k])
              for k in range(6)]
    single = [(0.55, 0.5, -0.3, 0.08), (0.75, 0.2, 0.15, 0.04)]
    return [helix, zigzag, single]


def write_curves(path, cs):
    with open(path, "w", newline="\n") as f:
        f.write("\n\n".join("\n".join("%.6f %.6f %.6f %.6f" % p for p in c) for c in cs) + "\n")


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    write_ellipsoids(os.path.join(OUT, "ellipsoids.ply"))
    print("wrote", os.path.join(OUT, "ellipsoids.ply"))
    write_sdf(os.path.join(OUT, "torus.sdf.vol"))
    print("wrote", os.path.join(OUT, "torus.sdf.vol"))
    write_curves(os.path.join(OUT, "curves.txt"), curves())
    print("wrote", os.path.join(OUT, "curves.txt"))
    tip = [(0.45, 0.1, -0.35, 0.0), (0.6, 0.7, -0.3, 0.12), (0.75, 0.35, 0.1, 0.1), (0.85, 0.15, 0.3, 0.0)]
    write_curves(os.path.join(OUT, "bspline.txt"), curves()[:2] + [tip])
    print("wrote", os.path.join(OUT, "bspline.txt"))
