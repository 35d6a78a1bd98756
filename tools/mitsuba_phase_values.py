#!/usr/bin/env python3
"""Pointwise values of Mitsuba 3.9.1 phase functions (rayleigh, tabphase,
sggx), for the `matches_mitsuba` unit tests in
crates/render/src/medium/phase/.

Usage (from the repository root):
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        /path/to/mitsuba-venv/bin/python tools/mitsuba_phase_values.py

For each case it prints Mitsuba's eval_pdf value at a medium interaction
whose `wi` points back along the incoming ray (Penumbra's `wi` too) for a
scattered direction `wo`. The sggx cases read S from a one-voxel 6-channel
grid written to a temporary .vol file.
"""
import os
import struct
import tempfile

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")

TABLE = "0.6, 0.2, 0.0, 0.0, 0.1, 0.3, 0.8, 2.5, 6.0"
WI = (0.3, -0.5, 0.8)
WOS = [(0.3, -0.5, 0.8), (-0.3, 0.5, -0.8), (0.9, 0.1, -0.2), (-0.4, -0.4, 0.3), (0.0, 1.0, 0.1)]
SGGX = [(1.0, 1.0, 1.0, 0.0, 0.0, 0.0), (0.05, 0.05, 1.0, 0.0, 0.0, 0.0),
        (1.0, 0.5, 0.3, 0.2, -0.1, 0.05)]


def norm(v):
    return mi.ScalarVector3f(v) / dr.norm(mi.ScalarVector3f(v))


def evaluate(phase, wi, wo):
    mei = dr.zeros(mi.MediumInteraction3f)
    mei.p = [0.5, 0.5, 0.5]
    mei.wi = norm(wi)
    mei.sh_frame = mi.Frame3f(mei.wi)
    ctx = mi.PhaseFunctionContext(None)
    value, pdf = phase.eval_pdf(ctx, mei, norm(wo))
    return float(value[0]) if dr.width(value) else float(value), float(pdf)


def vol_file(s):
    f = tempfile.NamedTemporaryFile(suffix=".vol", delete=False)
    f.write(b"VOL" + bytes([3]) + struct.pack("<5i", 1, 1, 1, 1, 6))
    f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1) + struct.pack("<6f", *s))
    f.close()
    return f.name


def main():
    phases = [("rayleigh", {"type": "rayleigh"}), ("tabphase", {"type": "tabphase", "values": TABLE})]
    files = []
    for s in SGGX:
        files.append(vol_file(s))
        phases.append(("sggx %s" % (s,), {"type": "sggx", "S": {
            "type": "gridvolume", "filename": files[-1], "filter_type": "nearest"}}))
    for label, d in phases:
        p = mi.load_dict(d)
        for wo in WOS:
            v, pdf = evaluate(p, WI, wo)
            print("%-44s wo %-22s eval %.7g  pdf %.7g" % (label, wo, v, pdf))
    for f in files:
        os.unlink(f)


if __name__ == "__main__":
    main()
