#!/usr/bin/env python3
"""Equal-time images of one scene side by side: Mitsuba 3 (llvm_ad_rgb),
Penumbra, Penumbra with path guiding, and the reference, as one PNG, each
captioned in the printed table with its spp and relMSE against the reference.

Usage (Mitsuba's Python, with Penumbra built in release):
    .venv-mitsuba/bin/python tools/guiding_side_by_side.py SCENE.xml REF.exr OUT.png [--budget 4]

REF.exr is the converged reference `penumbra bench --suite efficiency`
caches under target/bench-refs/ (Mitsuba at 32,768 spp, e.g.
door-ajar-32768.exr). relMSE is the bench's: mean over pixels and channels
of (a - b)^2 / (b^2 + 0.01), less the reference's own where its variance
(REF-var.exr, beside it) is there.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
import mitsuba as mi

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def load(path):
    return np.array(mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))


def rel_mse(a, b):
    return float(np.mean((a - b) ** 2 / (b * b + 0.01)))


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("reference")
    ap.add_argument("out")
    ap.add_argument("--budget", type=float, default=4.0)
    a = ap.parse_args()
    ref = load(a.reference)
    var_path = a.reference[:-4] + "-var.exr"
    floor = float(np.mean(load(var_path) / (ref * ref + 0.01))) if os.path.exists(var_path) else 0.0
    ref_spp = re.search(r"-(\d+)\.exr$", a.reference)
    tmp = tempfile.mkdtemp(prefix="penumbra-side-")
    images = []
    mi_out = os.path.join(tmp, "mitsuba.exr")
    run = subprocess.run(
        [sys.executable, os.path.join(ROOT, "tools/mitsuba_bench.py"), "--spp", "16", "--runs", "3",
         "--threads", "2", "--budget", str(a.budget), "--out", mi_out, a.scene],
        capture_output=True, text=True, check=True)
    spp = re.findall(r"mitsuba_budget .*?spp=(\d+)", run.stdout)
    images.append(("Mitsuba 3", spp[-1] if spp else "?", load(mi_out)))
    penumbra = os.path.join(ROOT, "target/release/penumbra")
    for name, extra in [("Penumbra", []), ("Penumbra, guided", ["--integrator", "path:guiding=true"])]:
        out = os.path.join(tmp, name.replace(", ", "-") + ".exr")
        run = subprocess.run(
            [penumbra, "render", "--quiet", "--spp", "1000000", "--seed", "1000", "--threads", "2",
             "--time", str(a.budget), "-o", out, a.scene] + extra,
            capture_output=True, text=True, check=True)
        spp = re.search(r"rendered (\d+) of", run.stderr)
        images.append((name, spp.group(1) if spp else "?", load(out)))
    images.append(("reference", ref_spp.group(1) if ref_spp else "?", ref))
    print(f"{a.scene}, {a.budget} s each (relMSE less the reference's own, {floor:.2e}):")
    for name, spp, img in images[:-1]:
        print(f"  {name:<18} {spp:>6} spp  relMSE {rel_mse(img, ref) - floor:.3e}")
    gap = np.ones((ref.shape[0], 2, 3), dtype=np.float32)
    row = np.concatenate(sum(([srgb(img), gap] for _, _, img in images), [])[:-1], axis=1)
    mi.Bitmap((row * 255 + 0.5).astype(np.uint8), mi.Bitmap.PixelFormat.RGB).write(a.out)


if __name__ == "__main__":
    mi.set_variant("scalar_rgb")
    main()
