#!/usr/bin/env python3
"""Write tests/scenes/textures/sunsky.exr, the procedural sky used by
tests/scenes/envmap_sun.xml (deterministic: no random numbers).

Usage:
    /work/.venv-mitsuba/bin/python tools/make_envmap.py [--out PATH] [--print]

The map is 128 x 64 (W x H), latitude-longitude, linear RGB float32, in
Mitsuba's envmap convention (see /work/shared/reference-renderer.md):
texel (row i, column j) sits at theta = pi i / (H - 1) (row 0 = +Y zenith,
last row = nadir) and phi = 2 pi (j + 0.5) / W, i.e. at the local direction
(sin phi sin theta, cos theta, -cos phi sin theta).

Content:
  * sky (theta < 90 deg): smooth gradient from a pale horizon to a deeper
    blue zenith, plus a soft glow around the sun;
  * below the horizon: a dim brownish ground, blended smoothly at the horizon;
  * sun: the texels whose centres lie within SUN_RADIUS_DEG of the sun centre
    (row 19 -> elevation 35.7 deg; column 0 -> local phi 1.4 deg, so the disc
    straddles the u = 0 / u = 1 seam: columns 127, 0 and 1) get a very bright
    constant radiance SUN_RGB (9 texels).

With envmap_sun.xml's <rotate y="1" angle="40"/> the sun's world direction
(from the scene towards the sun) is about (-0.507, 0.584, -0.635): up, to the
left of and behind the objects as seen by that scene's camera.

Writing uses mi.Bitmap(arr).write(path) (Mitsuba's own EXR writer), so only
Mitsuba + numpy are needed.
"""
import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
OUT = os.path.join(ROOT, "tests", "scenes", "textures", "sunsky.exr")

W, H = 128, 64
SUN_ROW, SUN_COL = 19, 0
SUN_RADIUS_DEG = 4.0
SUN_RGB = (800.0, 700.0, 560.0)
HORIZON_RGB = (0.75, 0.85, 1.0)
ZENITH_RGB = (0.18, 0.32, 0.8)
GROUND_RGB = (0.12, 0.1, 0.08)
GLOW_RGB = (1.2, 1.0, 0.7)


def texel_dir(np, i, j):
    theta = np.pi * i / (H - 1)
    phi = 2.0 * np.pi * (j + 0.5) / W
    return np.stack([np.sin(phi) * np.sin(theta), np.cos(theta),
                     -np.cos(phi) * np.sin(theta)], axis=-1)


def make(np):
    i, j = np.meshgrid(np.arange(H, dtype=np.float64),
                       np.arange(W, dtype=np.float64), indexing="ij")
    d = texel_dir(np, i, j)                       # H x W x 3
    sun = texel_dir(np, np.float64(SUN_ROW), np.float64(SUN_COL))
    cos_a = np.clip((d * sun).sum(axis=-1), -1.0, 1.0)
    ang = np.arccos(cos_a)                        # angle to the sun centre
    elev = np.arcsin(np.clip(d[..., 1], -1.0, 1.0))

    hz, zn, gr, gl = (np.array(c) for c in (HORIZON_RGB, ZENITH_RGB, GROUND_RGB, GLOW_RGB))
    t = np.sqrt(np.clip(np.sin(elev), 0.0, 1.0))[..., None]
    sky = hz * (1.0 - t) + zn * t
    sky = sky + gl * np.exp(-ang / 0.35)[..., None]
    # below the horizon: fade to the ground colour within ~10 degrees
    g = np.clip(-elev / math.radians(10.0), 0.0, 1.0)[..., None]
    img = sky * (1.0 - g) + gr * g
    disc = ang < math.radians(SUN_RADIUS_DEG)
    img[disc] = np.array(SUN_RGB)
    return img.astype(np.float32), int(disc.sum()), sun


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=OUT)
    ap.add_argument("--print", action="store_true", help="print sun facts")
    args = ap.parse_args()
    import numpy as np
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    img, n_sun, sun = make(np)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    mi.Bitmap(img).write(args.out)
    a = math.radians(40.0)
    world = (sun[0] * math.cos(a) + sun[2] * math.sin(a), sun[1],
             -sun[0] * math.sin(a) + sun[2] * math.cos(a))
    print(f"wrote {args.out}: {W}x{H}, {n_sun} sun texels, "
          f"{os.path.getsize(args.out)} bytes")
    if args.print:
        print("sun local dir", np.round(sun, 4), "world dir (rotate y 40)",
              np.round(world, 4))


if __name__ == "__main__":
    sys.exit(main())
