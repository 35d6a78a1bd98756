#!/usr/bin/env python3
"""Mitsuba 3 references of multichannel outputs (the `aov` and `moment`
integrators), for crates/scene/tests/channels.rs.

Usage:
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
    /work/.venv-mitsuba/bin/python tools/make_channel_refs.py NAME [--batch-spp S] [--batches B]

For tests/scenes/NAME.xml it renders B batches, each ONE ``mi.render`` call
of S samples per pixel with its own seed (one call, not several averaged:
channels such as the aov integrator's ``duv_dx`` depend on the render's
sample count, and the test renders batches of the same S), and writes
    tests/refs/NAME.exr      every channel of the film (mean of the batches)
    tests/refs/NAME_var.exr  the same channels: variance OF THE MEAN,
                             sum_b (m_b - M)^2 / (B (B - 1))
and records spp, batches and spp_per_batch in tests/refs/manifest.json.
Pixels where Mitsuba writes NaN (uv partials of rays that miss) stay NaN.
"""
import argparse
import json
import os
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("name")
    ap.add_argument("--batch-spp", type=int, default=64)
    ap.add_argument("--batches", type=int, default=32)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    import mitsuba as mi
    import numpy as np

    mi.set_variant(a.variant)
    mi.set_log_level(mi.LogLevel.Warn)
    try:
        import drjit as dr
        dr.set_thread_count(a.threads)
    except Exception:
        pass
    path = os.path.join(ROOT, "tests", "scenes", a.name + ".xml")
    scene = mi.load_file(path, spp=a.batch_spp)
    film = scene.sensors()[0].film()
    t0 = time.time()
    batches, names = [], None
    for b in range(a.batches):
        mi.render(scene, spp=a.batch_spp, seed=1000 + b)
        bmp = film.bitmap()
        names = [f.name for f in bmp.struct_()]
        batches.append(np.array(bmp, dtype=np.float64))
    x = np.stack(batches)
    mean = x.mean(axis=0)
    var = ((x - mean) ** 2).sum(axis=0) / (a.batches * (a.batches - 1))
    refs = os.path.join(ROOT, "tests", "refs")
    for suffix, img in (("", mean), ("_var", var)):
        bmp = mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.MultiChannel, names)
        bmp.write(os.path.join(refs, f"{a.name}{suffix}.exr"))
    manifest_path = os.path.join(refs, "manifest.json")
    with open(manifest_path) as f:
        manifest = json.load(f)
    manifest[a.name] = {
        "spp": a.batch_spp * a.batches,
        "batches": a.batches,
        "spp_per_batch": a.batch_spp,
        "variant": a.variant,
        "mitsuba": mi.__version__ if hasattr(mi, "__version__") else "3.9.1",
        "seconds": round(time.time() - t0, 2),
        "width": int(mean.shape[1]),
        "height": int(mean.shape[0]),
        "channels": names,
    }
    with open(manifest_path, "w") as f:
        json.dump(manifest, f, indent=2)
        f.write("\n")
    print(f"{a.name}: {len(names)} channels, {a.batches} x {a.batch_spp} spp in {time.time() - t0:.1f} s")


if __name__ == "__main__":
    main()
