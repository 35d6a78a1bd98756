#!/usr/bin/env python3
"""Time Mitsuba 3 rendering a scene, for comparison with Penumbra.

Usage:
    /work/.venv-mitsuba/bin/python tools/mitsuba_bench.py SCENE.xml
        [--variant llvm_ad_rgb|scalar_rgb] [--spp 64] [--threads 2]
        [--runs 2] [--budget SECONDS] [--out FILE.exr] [-D name=value ...]
        [--reference CHUNKS --out REF.exr --out-var REF-VAR.exr]

Loads the scene once (timed separately, not counted), then renders it
`--runs` times with different seeds. The first render includes Dr.Jit's
kernel tracing/compilation for the LLVM variant (unless the kernel was already
in Dr.Jit's on-disk cache, ~/.drjit); later renders reuse the compiled kernel.
Each render is forced to completion (the image is copied to numpy) before the
clock stops. For every render it prints one machine-readable line:

    mitsuba variant=V scene=S spp=N run=I jit=first|warm seconds=T samples_per_sec=R

followed by a summary line for the fastest warm run (LLVM: runs after the
first; scalar variants, which have no JIT: fastest of all runs):

    mitsuba variant=V scene=S spp=N seconds=T samples_per_sec=R first_seconds=T0 load_seconds=TL threads=K

samples_per_sec = width * height * spp / seconds (camera samples, i.e. paths).

With `--reference CHUNKS` it times nothing: it renders CHUNKS images of
`--spp` each with seeds 10000, 10001, ... and writes their mean to `--out`
and, to `--out-var`, the per-pixel variance of that mean (the chunks' sample
variance over CHUNKS): what a reference still owes to noise, which an
error measured against it includes and can subtract.
`spp` is passed to mi.render, overriding the scene's sample_count.

Tested with Mitsuba 3.9.1. The LLVM variant needs LLVM 19; set
DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 if it is not found
(the script sets it when that file exists and the variable is unset).
"""
import argparse
import os
import sys
import time

LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def main():
    ap = argparse.ArgumentParser(description="Time Mitsuba 3 on a scene.")
    ap.add_argument("scene")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--out", help="write the last render here (EXR)")
    ap.add_argument("--budget", type=float,
                    help="after the timed runs, render once more with as many spp as the "
                         "warm time per spp says fit in this many seconds, and time that")
    ap.add_argument("--reference", type=int, metavar="CHUNKS",
                    help="render a converged reference: the mean of CHUNKS renders of --spp")
    ap.add_argument("--out-var", help="with --reference: the variance of its mean (EXR)")
    ap.add_argument("-D", dest="defines", action="append", default=[],
                    metavar="NAME=VALUE", help="scene parameter (like mitsuba -D)")
    args = ap.parse_args()

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ \
            and os.path.exists(LLVM19):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM19

    import drjit as dr
    import mitsuba as mi
    import numpy as np

    dr.set_thread_count(args.threads)
    mi.set_variant(args.variant)
    mi.set_log_level(mi.LogLevel.Warn)

    params = {}
    for d in args.defines:
        k, v = d.split("=", 1)
        params[k] = v

    t0 = time.perf_counter()
    scene = mi.load_file(args.scene, **params)
    load_s = time.perf_counter() - t0

    film = scene.sensors()[0].film()
    w, h = film.crop_size()
    nsamples = int(w) * int(h) * args.spp
    name = os.path.basename(args.scene)

    if args.reference:
        k = args.reference
        total = total_sq = None
        t0 = time.perf_counter()
        for i in range(k):
            a = np.array(mi.render(scene, spp=args.spp, seed=10000 + i), dtype=np.float64)
            assert np.all(np.isfinite(a)), "non-finite pixels"
            total = a if total is None else total + a
            total_sq = a * a if total_sq is None else total_sq + a * a
        mean = total / k
        var_of_mean = np.maximum(total_sq / k - mean * mean, 0.0) * (k / (k - 1)) / k if k > 1 \
            else np.zeros_like(mean)
        mi.Bitmap(mean.astype(np.float32)).write(args.out)
        if args.out_var:
            mi.Bitmap(var_of_mean.astype(np.float32)).write(args.out_var)
        print(f"mitsuba_reference variant={args.variant} scene={name} spp={k * args.spp} "
              f"seconds={time.perf_counter() - t0:.1f}", flush=True)
        return 0

    times = []
    for run in range(args.runs):
        t0 = time.perf_counter()
        img = mi.render(scene, spp=args.spp, seed=run)
        arr = np.array(img)  # forces evaluation
        dr.sync_thread()
        dt = time.perf_counter() - t0
        assert np.all(np.isfinite(arr)), "non-finite pixels"
        times.append(dt)
        print(f"mitsuba variant={args.variant} scene={name} spp={args.spp} run={run} "
              f"jit={'first' if run == 0 else 'warm'} seconds={dt:.4f} "
              f"samples_per_sec={nsamples / dt:.0f}", flush=True)

    # LLVM: the first render pays for kernel tracing/compilation, so report the
    # fastest later run. Scalar variants have no JIT: fastest of all runs.
    jit = not args.variant.startswith("scalar")
    best = min(times[1:]) if (jit and len(times) > 1) else min(times)
    print(f"mitsuba variant={args.variant} scene={name} spp={args.spp} "
          f"seconds={best:.4f} samples_per_sec={nsamples / best:.0f} "
          f"first_seconds={times[0]:.4f} load_seconds={load_s:.4f} "
          f"threads={args.threads}", flush=True)

    if args.budget:
        # The time per spp of a short render overstates a long one's (each
        # render has fixed costs), so the first guess can fall well short of
        # the budget: rescale from the render just timed, at most twice more,
        # until one lasts within 10 % of it. The last render is the one kept
        # (and the last printed line the one a caller reads).
        spp = max(1, int(args.budget / (best / args.spp)))
        for attempt in range(3):
            t0 = time.perf_counter()
            img = mi.render(scene, spp=spp, seed=1000)
            arr = np.array(img)
            dr.sync_thread()
            dt = time.perf_counter() - t0
            print(f"mitsuba_budget variant={args.variant} scene={name} spp={spp} seconds={dt:.4f}", flush=True)
            if abs(dt - args.budget) <= 0.1 * args.budget:
                break
            spp = max(1, int(spp * args.budget / dt))
    if args.out:
        mi.Bitmap(img).write(args.out)


if __name__ == "__main__":
    sys.exit(main())
