#!/usr/bin/env python3
"""Regenerate Penumbra's converged Mitsuba 3 reference images.

Usage:
    /work/.venv-mitsuba/bin/python tools/make_refs.py [--spp N] [--batches B]
        [--variant llvm_ad_rgb|scalar_rgb] [--threads T] [--write-meshes]
        [scene ...]

    scene: names (``cbox_diffuse``) or paths (``tests/scenes/cbox_diffuse.xml``);
           default: every ``tests/scenes/*.xml``.

For each scene it writes
    tests/refs/<name>.exr      mean image, linear RGB float32 (mi.Bitmap.write)
    tests/refs/<name>_var.exr  per-pixel, per-channel variance OF THE MEAN
and updates tests/refs/manifest.json (spp, batches, variant, seconds, ...).

Method: the total sample count (``--spp``, default per scene in SPP below) is
split into B (default 16, at least 8) independent batches with distinct seeds.
Each batch is the average of one or more ``mi.render(scene, spp=s, seed=k)``
calls (s = a power of 4, so ``stratified`` samplers keep their meaning).
With batch means m_1..m_B and overall mean M = mean(m_b), the variance of M is
estimated per pixel and channel as  sum_b (m_b - M)^2 / (B (B - 1)).
(With B = 16 that estimate itself has ~35 % relative spread per pixel; tests
should use it with some margin or pool it over regions.)

The scene's own sampler type is kept; its ``sample_count`` is overridden by
``spp`` passed to mi.render.  The scene's $spp default is also set to the batch
size with ``-D spp=...`` semantics (``mi.load_file(path, spp=...)``).

Mitsuba version used for the checked-in references: 3.9.1, variant
llvm_ad_rgb (LLVM 19 via DRJIT_LIBLLVM_PATH), 2 threads.  ``scalar_rgb`` gives
the same expectation but is ~5-10x slower.

``--write-meshes`` (re)generates the small OBJ/PLY files in
tests/scenes/meshes/ used by mesh_ply_obj.xml (deterministic).
"""
import argparse
import glob
import json
import math
import os
import struct
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENES = os.path.join(ROOT, "tests", "scenes")
REFS = os.path.join(ROOT, "tests", "refs")
LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"

# Default total samples per pixel per scene (override with --spp).
SPP = {
    "cbox_diffuse": 32768,
    "ptracer_box": 16384,
    "spheres_env": 16384,
    "mesh_ply_obj": 16384,
    "glass_caustic": 65536,
    "direct_light": 16384,
    "hidden_emitters": 16384,
    "point_light": 8192,
    "spot_light": 65536,
    "envmap_sun": 65536,
    "window": 65536,
    "window_sky": 32768,
    "many_lights": 65536,
    "direct_integrator": 16384,
    "rough_spheres": 65536,
    "textured": 16384,
    "format_features": 16384,
    "sensors_samplers": 16384,
    "orthographic": 16384,
    "principled": 65536,
    "vertex_colors": 65536,
    "principledthin": 65536,
    "fog_spot": 65536,
    "smoke_grid": 32768,
    "glass_medium": 65536,
    "emitter_in_medium": 65536,
    "spot_texture": 32768,
    "pplastic": 65536,
    "hair": 65536,
    "measured": 65536,
    "area_texture": 16384,
    "projector": 16384,
    "directionalarea": 8192,
    "sunsky": 8192,
    "timed_sunsky": 8192,
    "old_format": 16384,
    "ellipsoids": 16384,
    "sdfgrid": 32768,
    "linearcurve": 16384,
    "bsplinecurve": 16384,
    "phase_rayleigh": 32768,
    "phase_tabphase": 32768,
    "phase_sggx": 32768,
    "volume_texture": 16384,
    "batch_sensor": 16384,
    "phase_sggx_heterogeneous": 32768,
}
DEFAULT_SPP = 8192
# Scenes whose reference is rendered with Mitsuba's `independent` sampler in
# place of the scene's own: the expectation does not depend on the sampler,
# but Mitsuba 3.9.1's `ldsampler` is biased on orthographic.xml (the cube is
# 2.5 % brighter than with its independent sampler at depth >= 3, while
# Penumbra's ldsampler and independent samplers agree within 0.1 %).
INDEPENDENT_REF = {"orthographic"}
# Scenes rendered with Dr.Jit's evaluated (not symbolic) loops and calls:
# Mitsuba 3.9.1's `timed_sunsky` reduces a mask with dr::any while it
# evaluates the sun, which symbolic loops do not permit (jit_var_schedule:
# "not permitted"). The expectation does not depend on the mode.
EVALUATED_MODE = {"timed_sunsky"}
# Largest single mi.render call (spp); keeps LLVM wavefronts at a few M lanes.
MAX_CHUNK = 1024


# ---------------------------------------------------------------------------
# Meshes for mesh_ply_obj.xml
# ---------------------------------------------------------------------------
def icosahedron():
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
         (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
         (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
         (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    return v, f


def subdivide(v, f):
    v = list(v)
    cache = {}

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in cache:
            p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
            n = math.sqrt(sum(x * x for x in p))
            v.append(tuple(x / n for x in p))
            cache[key] = len(v) - 1
        return cache[key]

    nf = []
    for a, b, c in f:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    return v, nf


def write_meshes():
    d = os.path.join(SCENES, "meshes")
    os.makedirs(d, exist_ok=True)
    # 1) icosphere (2 subdivisions: 162 vertices, 320 triangles), unit radius,
    #    counter-clockwise (outward) winding, explicit smooth vertex normals.
    v, f = icosahedron()
    for _ in range(2):
        v, f = subdivide(v, f)
    with open(os.path.join(d, "icosphere.obj"), "w", newline="\n") as o:
        o.write("# unit icosphere, 2 subdivisions: %d vertices, %d triangles\n"
                "# generated by tools/make_refs.py --write-meshes\n" % (len(v), len(f)))
        o.write("o icosphere\n")
        for p in v:
            o.write("v %.6f %.6f %.6f\n" % p)
        for p in v:
            o.write("vn %.6f %.6f %.6f\n" % p)
        for a, b, c in f:
            o.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))
    # 2) ground quad [-2,2]^2 in y = 0 as ONE quad face (needs triangulation),
    #    wound clockwise seen from above, i.e. its geometric normal is -y.
    #    No normals in the file.
    with open(os.path.join(d, "ground_quad.obj"), "w", newline="\n") as o:
        o.write("# 4 x 4 quad in y = 0, one quad face, normal -y (clockwise from above)\n"
                "# generated by tools/make_refs.py --write-meshes\n")
        for p in [(-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2)]:
            o.write("v %g %g %g\n" % p)
        o.write("f 1 2 3 4\n")
    # 3) icosahedron as binary little-endian PLY (12 vertices, 20 faces),
    #    positions only, outward winding.
    v, f = icosahedron()
    hdr = ("ply\nformat binary_little_endian 1.0\n"
           "comment unit icosahedron, generated by tools/make_refs.py --write-meshes\n"
           "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
           "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
           % (len(v), len(f)))
    with open(os.path.join(d, "icosahedron.ply"), "wb") as o:
        o.write(hdr.encode("ascii"))
        for p in v:
            o.write(struct.pack("<3f", *p))
        for tri in f:
            o.write(struct.pack("<B3i", 3, *tri))
    print("wrote meshes to", d)


# ---------------------------------------------------------------------------
# References
# ---------------------------------------------------------------------------
def chunks_for(spp_batch):
    """Split a batch into mi.render calls of 4^k spp each (<= MAX_CHUNK).

    Powers of four are squares of powers of two, which the ``stratified``
    sampler needs (it silently rounds other counts up, which would break the
    weighting of the chunks)."""
    out = []
    left = spp_batch
    while left > 0:
        s = 1
        while s * 4 <= min(left, MAX_CHUNK):
            s *= 4
        out.append(s)
        left -= s
    return out


def render_ref(mi, np, path, spp, batches, variant):
    name = os.path.splitext(os.path.basename(path))[0]
    per_batch = max(1, spp // batches)
    chunks = chunks_for(per_batch)
    per_batch = sum(chunks)
    import drjit as dr
    for flag in (dr.JitFlag.SymbolicLoops, dr.JitFlag.SymbolicCalls):
        dr.set_flag(flag, name not in EVALUATED_MODE)
    if name in INDEPENDENT_REF:
        text = open(path).read()
        for t in ("ldsampler", "multijitter", "orthogonal", "stratified"):
            text = text.replace('<sampler type="%s">' % t, '<sampler type="independent">')
        mi.Thread.thread().file_resolver().prepend(os.path.dirname(os.path.abspath(path)))
        scene = mi.load_string(text, spp=str(chunks[0]))
    else:
        scene = mi.load_file(path, spp=str(chunks[0]))
    t0 = time.perf_counter()
    seed = 0
    means = []
    for b in range(batches):
        acc = None
        for c in chunks:
            img = np.array(mi.render(scene, spp=c, seed=seed), dtype=np.float64)
            seed += 1
            acc = img * c if acc is None else acc + img * c
        means.append(acc / per_batch)
    secs = time.perf_counter() - t0
    m = np.stack(means)[..., :3]
    mean = m.mean(axis=0)
    var = ((m - mean) ** 2).sum(axis=0) / (batches * (batches - 1))
    assert np.all(np.isfinite(mean)), "non-finite pixels in mean"
    mi.Bitmap(mean.astype(np.float32)).write(os.path.join(REFS, name + ".exr"))
    mi.Bitmap(var.astype(np.float32)).write(os.path.join(REFS, name + "_var.exr"))
    total = per_batch * batches
    lum = mean.mean(axis=2)
    lit = lum > 0.05 * max(lum.max(), 1e-12)
    rel = np.sqrt(var.mean(axis=2))[lit] / np.maximum(lum[lit], 1e-12)
    info = {
        "spp": total, "batches": batches, "spp_per_batch": per_batch,
        "variant": variant, "mitsuba": mi.__version__,
        "seconds": round(secs, 2), "width": int(mean.shape[1]), "height": int(mean.shape[0]),
        "rel_stderr_median": float(np.median(rel)) if rel.size else 0.0,
        "rel_stderr_p95": float(np.percentile(rel, 95)) if rel.size else 0.0,
    }
    print(f"{name}: {mean.shape[1]}x{mean.shape[0]} spp={total} ({batches} batches x "
          f"{per_batch}) time={secs:.1f}s  mean rgb={mean.mean(axis=(0, 1)).round(4)}  "
          f"rel.stderr lit px: median={info['rel_stderr_median']:.4f} "
          f"p95={info['rel_stderr_p95']:.4f}", flush=True)
    return name, info


def main():
    ap = argparse.ArgumentParser(description="Render Mitsuba references for tests/scenes.")
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--spp", type=int, default=None, help="total spp per scene")
    ap.add_argument("--batches", type=int, default=16)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--write-meshes", action="store_true")
    args = ap.parse_args()
    if args.batches < 8:
        ap.error("--batches must be at least 8")

    if args.write_meshes:
        write_meshes()
        if not args.scenes:
            return

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ \
            and os.path.exists(LLVM19):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM19
    import drjit as dr
    import mitsuba as mi
    import numpy as np
    dr.set_thread_count(args.threads)
    mi.set_variant(args.variant)
    mi.set_log_level(mi.LogLevel.Warn)

    print(f"Mitsuba {mi.__version__}, variant {args.variant}, {args.threads} threads, "
          f"{args.batches} batches", flush=True)
    paths = []
    for s in args.scenes or sorted(glob.glob(os.path.join(SCENES, "*.xml"))):
        if not s.endswith(".xml"):
            s = os.path.join(SCENES, s + ".xml")
        paths.append(os.path.abspath(s))

    os.makedirs(REFS, exist_ok=True)
    man_path = os.path.join(REFS, "manifest.json")
    manifest = json.load(open(man_path)) if os.path.exists(man_path) else {}
    for p in paths:
        name = os.path.splitext(os.path.basename(p))[0]
        spp = args.spp or SPP.get(name, DEFAULT_SPP)
        name, info = render_ref(mi, np, p, spp, args.batches, args.variant)
        manifest[name] = info
        with open(man_path, "w") as f:
            json.dump(dict(sorted(manifest.items())), f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    sys.exit(main())
