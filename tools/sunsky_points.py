#!/usr/bin/env python3
"""Print Mitsuba 3's `sunsky` / `timed_sunsky` radiance, pdf and direction
samples for the cases in crates/scene/tests/sunsky.rs (which hard-codes this
output).

Usage:
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        .venv-mitsuba/bin/python tools/sunsky_points.py

Mitsuba 3.9.1, variant llvm_ad_rgb. For each case (an emitter given as XML
properties) it prints, in world space:
  eval  d  ->  radiance (eval with si.wi = -d), pdf_direction
  samp  u  ->  sampled direction, pdf, weight (= radiance / pdf)
"""
import drjit as dr
import mitsuba as mi

mi.set_variant("llvm_ad_rgb")

# (name, emitter dict): the same cases as the Rust test.
CASES = [
    ("dir", {"type": "sunsky", "sun_direction": [0.5, 0.2, 0.8]}),
    (
        "tokyo",
        {
            "type": "sunsky",
            "turbidity": 5.5,
            "albedo": {"type": "rgb", "value": [0.1, 0.5, 0.9]},
            "sun_aperture": 2.0,
            "sun_scale": 0.5,
            "sky_scale": 2.0,
            "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90),
        },
    ),
    (
        "low_complex",
        {
            "type": "sunsky",
            "sun_direction": [-0.6, 0.75, 0.18],
            "turbidity": 2.0,
            "complex_sun": True,
            "albedo": 0.8,
        },
    ),
    (
        "paris_spring",
        {
            "type": "timed_sunsky",
            "latitude": 48.85,
            "longitude": 2.35,
            "timezone": 1.0,
            "start_year": 2025,
            "start_month": 3,
            "start_day": 1,
            "end_month": 4,
            "end_year": 2025,
            "window_start_time": 8.0,
            "window_end_time": 18.0,
            "shutter_open": -1.0,
            "shutter_close": 1.3,
            "turbidity": 4.0,
            "sun_aperture": 1.0,
        },
    ),
    ("timed_default", {"type": "timed_sunsky", "shutter_open": -0.4, "shutter_close": 0.6}),
]

DIRS = [
    (0.02, 0.03, 1.0),
    (0.3, -0.2, 0.9),
    (-0.7, 0.1, 0.2),
    (0.1, 0.9, 0.05),
    (0.6, 0.6, 0.5),
    (-0.2, -0.5, 0.6),
    (0.01, 1.0, 0.02),
    (0.0, 0.3, 0.95),
    (0.5, 0.2, 0.8),
    (0.4, 0.3, -0.2),
]

SAMPLES = [
    (0.05, 0.3),
    (0.2, 0.8),
    (0.45, 0.5),
    (0.6, 0.1),
    (0.8, 0.65),
    (0.93, 0.4),
    (0.97, 0.9),
    (0.995, 0.55),
    (0.9995, 0.2),
]


def main():
    for name, props in CASES:
        e = mi.load_dict(props)
        print(f"case {name}")
        it = dr.zeros(mi.Interaction3f)
        for d in DIRS:
            v = dr.normalize(mi.Vector3f(*d))
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = -v
            rad = e.eval(si)
            ds = dr.zeros(mi.DirectionSample3f)
            ds.d = v
            pdf = e.pdf_direction(it, ds)
            r = [rad.x[0], rad.y[0], rad.z[0]]
            print(f"eval {d[0]:g} {d[1]:g} {d[2]:g} -> {r[0]:.7g} {r[1]:.7g} {r[2]:.7g} {pdf[0]:.7g}")
        for u in SAMPLES:
            ds, w = e.sample_direction(it, mi.Point2f(*u))
            print(
                f"samp {u[0]:g} {u[1]:g} -> {ds.d.x[0]:.7g} {ds.d.y[0]:.7g} {ds.d.z[0]:.7g} "
                f"{ds.pdf[0]:.7g} {w.x[0]:.7g} {w.y[0]:.7g} {w.z[0]:.7g}"
            )


if __name__ == "__main__":
    main()
