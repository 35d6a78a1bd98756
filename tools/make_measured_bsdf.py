#!/usr/bin/env python3
"""Write small synthetic RGL `.bsdf` files (Mitsuba's tensor format) with every
field Mitsuba 3.9.1's `measured` BSDF reads, for Penumbra's tests (deterministic).

Usage: python3 tools/make_measured_bsdf.py

The tables are smooth positive functions of their coordinates, not a
measurement nor a fit of an analytic BRDF: they exercise the format, the
interpolation and the warps, which is what the pointwise comparison with
Mitsuba (tools/mitsuba_measured_values.py) checks.

tests/scenes/measured/iso.bsdf: phi_i = [0] (isotropic), theta_i 4 values,
  ndf/sigma 9 x 7, vndf 1 x 4 x 9 x 7, luminance and rgb 8 x 8, jacobian 1.
  Its sigma does not depend on the azimuth, as an isotropic material's does
  not: Mitsuba 3.9.1 leaves `m_reduction` unset for isotropic files
  (mitsuba3 pull request #1850), so whether it mirrors wi into a half turn
  before looking sigma up at phi_i depends on uninitialised memory; with a
  phi-independent sigma the result is the same either way.
tests/scenes/measured/aniso2.bsdf: phi_i = 3 values over [-pi, 0] (Mitsuba's
  reduction 2: mirrored into a half turn), theta_i 3 values, jacobian 0,
  rgb scaled by 0.12 so that, without the NDF / (4 sigma) factor, the
  albedo stays below 1 (tests/scenes/measured.xml renders it).
tests/scenes/measured/aniso4.bsdf: phi_i = 3 values over [-pi, -pi/2]
  (reduction 4: mirrored into a quarter turn), theta_i 4 values, ndf/sigma
  7 x 6, luminance and rgb 7 x 7, jacobian 1.
"""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "measured")
import sys
sys.path.insert(0, HERE)
from make_tensor_files import tensor  # noqa: E402


def f32(values):
    return struct.pack("<%df" % len(values), *values)


def table(shape, fn):
    vals = []

    def rec(prefix, dims):
        if not dims:
            vals.append(fn(*prefix))
            return
        for i in range(dims[0]):
            rec(prefix + [i], dims[1:])
    rec([], list(shape))
    return vals


def bsdf(phi_i, theta_i, hw, n, jacobian, sigma_phi, rgb_scale):
    P, T = len(phi_i), len(theta_i)
    h, w = hw

    def nd(y, x):
        return 0.2 + math.exp(-4.0 * (x / (w - 1)) ** 2) * (1.0 + 0.3 * math.cos(2 * math.pi * y / (h - 1)))

    def sg(y, x):
        return 0.5 + 0.4 * (x / (w - 1)) + sigma_phi * math.sin(3.0 * y / (h - 1))

    def vn(p, t, y, x):
        return 0.1 + math.exp(-3.0 * (x / (w - 1) - 0.2 * t / max(T - 1, 1)) ** 2) * (1.2 + math.sin(y * 0.7 + p))

    def lum(p, t, y, x):
        return 0.3 + (1.0 + 0.5 * p + 0.3 * t) * math.exp(-2.0 * ((x / (n - 1)) ** 2 + (y / (n - 1) - 0.3) ** 2))

    def rgb(p, t, c, y, x):
        return rgb_scale * (0.5 + 0.2 * c) * lum(p, t, y, x) * (1.0 + 0.1 * c * x / (n - 1))

    desc = b"penumbra synthetic test material"
    return tensor([
        ("description", "u8", [len(desc)], desc),
        ("phi_i", "f32", [P], f32(phi_i)),
        ("theta_i", "f32", [T], f32(theta_i)),
        ("ndf", "f32", [h, w], f32(table([h, w], nd))),
        ("sigma", "f32", [h, w], f32(table([h, w], sg))),
        ("vndf", "f32", [P, T, h, w], f32(table([P, T, h, w], vn))),
        ("luminance", "f32", [P, T, n, n], f32(table([P, T, n, n], lum))),
        ("rgb", "f32", [P, T, 3, n, n], f32(table([P, T, 3, n, n], rgb))),
        ("jacobian", "u8", [1], bytes([jacobian])),
    ])


def main():
    os.makedirs(OUT, exist_ok=True)
    files = {
        "iso.bsdf": bsdf([0.0], [0.0, 0.4, 0.9, 1.4], (9, 7), 8, 1, 0.0, 1.0),
        "aniso2.bsdf": bsdf([-math.pi, -math.pi / 2, 0.0], [0.0, 0.7, 1.4], (6, 5), 6, 0, 0.05, 0.12),
        "aniso4.bsdf": bsdf([-math.pi, -0.75 * math.pi, -math.pi / 2], [0.0, 0.5, 1.0, 1.5], (7, 6), 7, 1, 0.05, 1.0),
    }
    for name, data in files.items():
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(data)
        print(f"wrote {os.path.join(OUT, name)} ({len(data)} bytes)")


if __name__ == "__main__":
    main()
