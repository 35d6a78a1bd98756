#!/usr/bin/env python3
"""Pointwise values of Mitsuba 3.9.1 BSDFs, for the `matches_mitsuba` unit
tests beside Penumbra's BSDF models (crates/render/src/bsdf/*.rs).

Usage (from the repository root):
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        /path/to/mitsuba-venv/bin/python tools/mitsuba_bsdf_values.py [pplastic|hair|measured]

For each case it prints Mitsuba's eval (which includes |cos θ| of the light
direction), pdf, and the camera-side / light-side directions, in the local
shading frame (normal +z). Mitsuba's `si.wi` is Penumbra's `wo` (towards the
camera), Mitsuba's `wo` Penumbra's `wi`.
"""
import sys

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")


def norm(v):
    return mi.ScalarVector3f(v) / dr.norm(mi.ScalarVector3f(v))


def evaluate(d, wo, wi, uv=(0.5, 0.5)):
    b = mi.load_dict(d)
    si = mi.SurfaceInteraction3f()
    si.p = [0, 0, 0]
    si.n = [0, 0, 1]
    si.uv = uv
    si.sh_frame = mi.Frame3f([1, 0, 0], [0, 1, 0], [0, 0, 1])
    si.wi = norm(wo)
    ctx = mi.BSDFContext()
    f = b.eval(ctx, si, norm(wi))
    p = b.pdf(ctx, si, norm(wi))
    return [float(f[0]), float(f[1]), float(f[2])], float(p)


def show(label, d, wo, wi):
    f, p = evaluate(d, wo, wi)
    print("%-40s eval %.7g, %.7g, %.7g  pdf %.7g" % (label, f[0], f[1], f[2], p))


def pplastic():
    wo = (0.3, 0.2, 0.8)
    wi_r = (-0.5, 0.1, 0.6)
    wi_g = (0.9, -0.2, 0.1)
    base = {"type": "pplastic", "int_ior": 1.49,
            "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.3, 0.8]}}
    for kind, au, av, x, y in [("ggx", 0.3, 0.3, wo, wi_r), ("beckmann", 0.2, 0.2, wo, wi_r),
                               ("ggx", 0.1, 0.5, wi_g, wo), ("beckmann", 0.4, 0.15, wo, wi_g)]:
        d = dict(base, distribution=kind)
        if au == av:
            d["alpha"] = au
        else:
            d["alpha_u"], d["alpha_v"] = au, av
        show("pplastic %s %g/%g" % (kind, au, av), d, x, y)


def hair():
    wo = (0.3, 0.2, 0.8)
    for l, a, tilt, sigma_a, wi in [(0.3, 0.3, 2.0, None, (-0.5, 0.1, 0.6)),
                                    (0.3, 0.3, 2.0, None, (-0.2, -0.3, -0.9)),
                                    (0.1, 0.5, 5.0, (0.2, 0.3, 0.5), (-0.5, -0.25, 0.6)),
                                    (0.7, 0.2, 0.0, (0.05, 0.05, 0.1), (0.4, 0.3, -0.8))]:
        d = {"type": "hair", "longitudinal_roughness": l, "azimuthal_roughness": a, "scale_tilt": tilt}
        if sigma_a is not None:
            d["sigma_a"] = {"type": "rgb", "value": list(sigma_a)}
        show("hair %g/%g/%g sigma_a %s wi %s" % (l, a, tilt, sigma_a, wi), d, wo, wi)


if __name__ == "__main__":
    which = sys.argv[1:] or ["pplastic"]
    for w in which:
        globals()[w]()
