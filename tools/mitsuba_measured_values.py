#!/usr/bin/env python3
"""Print Mitsuba 3.9.1's `measured` eval/pdf/sample on the files of
tools/make_measured_bsdf.py, as the Rust tables of crates/scene/tests/measured.rs.

Usage: DRJIT_LIBLLVM_PATH=... python tools/mitsuba_measured_values.py
"""
import math
import os
import mitsuba as mi

mi.set_variant("llvm_ad_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
DIR = os.path.join(os.path.dirname(HERE), "tests", "scenes", "measured")


def d(theta, phi):
    return [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]


PAIRS = [((0.3, 0.5), (0.6, 2.5)), ((1.0, -1.2), (0.2, 0.3)), ((0.7, 2.8), (1.1, -0.4)),
         ((0.05, 1.0), (0.5, 1.0)), ((1.3, -2.0), (1.2, 1.5)), ((0.9, -0.3), (0.4, -2.9))]
SAMPLES = [((0.3, 0.5), (0.25, 0.75)), ((1.0, -1.2), (0.9, 0.1)), ((0.7, 2.8), (0.5, 0.5)),
           ((1.3, -2.0), (0.05, 0.6)), ((0.9, -0.3), (0.7, 0.35))]

for name in ["iso.bsdf", "aniso2.bsdf", "aniso4.bsdf"]:
    b = mi.load_dict({"type": "measured", "filename": os.path.join(DIR, name)})
    ctx = mi.BSDFContext()
    print("// %s: (wi, wo, eval, pdf)" % name)
    for (ti, pi), (to, po) in PAIRS:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*d(ti, pi))
        wo = mi.Vector3f(*d(to, po))
        e = b.eval(ctx, si, wo)
        p = b.pdf(ctx, si, wo)
        print("    ([%r, %r], [%r, %r], [%.9g, %.9g, %.9g], %.9g)," % (ti, pi, to, po, e.x[0], e.y[0], e.z[0], p[0]))
    print("// %s: (wi, u, wo, pdf, weight)" % name)
    for (ti, pi), u in SAMPLES:
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*d(ti, pi))
        bs, w = b.sample(ctx, si, 0.5, mi.Point2f(*u))
        print("    ([%r, %r], [%r, %r], [%.9g, %.9g, %.9g], %.9g, [%.9g, %.9g, %.9g])," % (
            ti, pi, u[0], u[1], bs.wo.x[0], bs.wo.y[0], bs.wo.z[0], bs.pdf[0], w.x[0], w.y[0], w.z[0]))
