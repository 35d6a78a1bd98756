#!/usr/bin/env python3
"""Print Mitsuba 3.9.1's MarginalContinuous2D2 sample/invert/eval on the grid of
crates/render/src/sampling/marginal2d.rs's tests (7 x 5, parameters
[0, 1, 3] and [-1, 2]), as the Rust table `MITSUBA` there.

Usage: DRJIT_LIBLLVM_PATH=... python tools/mitsuba_marginal2d_values.py
"""
import math
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")

w, h, slices = 7, 5, 6
vals = []
for s in range(slices):
    for y in range(h):
        for x in range(w):
            fx, fy = np.float32(x / (w - 1)), np.float32(y / (h - 1))
            v = np.float32(0.05) + np.float32(math.sin(np.float32(fx * np.float32(3.0) + np.float32(s)))) ** 2 \
                * (np.float32(1.0) + np.float32(2.0) * fy * fy) + np.float32(s) * fx
            vals.append(np.float32(v))
data = np.array(vals, dtype=np.float32).reshape(3, 2, h, w)
m = mi.MarginalContinuous2D2(data, [[0.0, 1.0, 3.0], [-1.0, 2.0]], normalize=True)
cases = [((0.3, 0.7), (0.4, 1.3)), ((0.9, 0.1), (2.9, 2.0)), ((0.05, 0.95), (5.0, -3.0)), ((0.5, 0.5), (1.0, 0.5))]
print("const MITSUBA: [Case; %d] = [" % len(cases))
for u, p in cases:
    param = [mi.Float(p[0]), mi.Float(p[1])]
    s, pdf = m.sample(mi.Point2f(*u), param)
    e = m.eval(mi.Point2f(*u), param)
    print("    ([%r, %r], [%r, %r], [%.9g, %.9g], %.9g, %.9g)," % (u[0], u[1], p[0], p[1], s.x[0], s.y[0], pdf[0], e[0]))
print("];")
