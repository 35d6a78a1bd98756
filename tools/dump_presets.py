#!/usr/bin/env python3
"""Generate crates/render/src/bsdf/presets.rs from the installed Mitsuba 3.

Usage:
    /work/.venv-mitsuba/bin/python tools/dump_presets.py [--out PATH] [--check]

What it extracts (Mitsuba 3.9.1, variant ``scalar_rgb``):

* Named dielectric IORs: the table ``ior_data`` in
  ``mitsuba/include/mitsuba/render/ior.h`` (shipped with the pip package),
  parsed from the header so the values are exactly Mitsuba's.  Mitsuba matches
  these names case-insensitively (it lower-cases the name first).
* Named conductor materials: every ``data/ior/<name>.eta.spd`` /
  ``<name>.k.spd`` pair shipped with the package.  In the ``*_rgb`` variants
  Mitsuba converts each measured spectrum to an (unbounded) sRGB colour when
  the plugin is created; we load ``{'type': 'conductor', 'material': name}``
  and read ``eta.value`` / ``k.value`` from ``mi.traverse`` (they are
  ``SRGBReflectanceSpectrum`` textures whose RGB value is returned unchanged by
  ``eval`` in RGB mode).  As a cross-check the script also samples the BSDF at
  normal incidence and compares the returned weight with the exact conductor
  Fresnel term computed from those eta/k.  Conductor names are case-sensitive
  in Mitsuba (they are file names).
* ``none``: Mitsuba's default material.  It is *not* eta=k=0: the plugin uses
  eta = 0 and k = 1 (complex IOR = i), for which the conductor Fresnel term is
  exactly 1 at every angle, i.e. a perfect 100 % mirror.

The generated file depends only on std.
"""
import argparse
import os
import re
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DEFAULT_OUT = os.path.join(ROOT, "crates", "render", "src", "bsdf", "presets.rs")


def f32_lit(x):
    """Shortest Rust literal that round-trips to the same f32."""
    v = np.float32(x)
    s = np.format_float_positional(v, unique=True, trim="0")
    if s.endswith("."):
        s += "0"
    if "." not in s and "e" not in s:
        s += ".0"
    return s


def fresnel_conductor(cos_i, eta, k):
    # Exact unpolarised Fresnel reflectance for a complex IOR eta + i k
    # (same formula as Mitsuba's fresnel_conductor).
    c2 = cos_i * cos_i
    s2 = 1.0 - c2
    e2, k2 = eta * eta, k * k
    t0 = e2 - k2 - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * e2 * k2)
    a = np.sqrt(0.5 * (a2b2 + t0))
    t1 = a2b2 + c2
    t2 = 2.0 * cos_i * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    return 0.5 * (rp + rs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=DEFAULT_OUT)
    ap.add_argument("--check", action="store_true",
                    help="only compare with the existing file, do not write")
    args = ap.parse_args()

    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    pkg = os.path.dirname(mi.__file__)

    # ---- dielectric IORs, parsed from ior.h --------------------------------
    hdr = open(os.path.join(pkg, "include", "mitsuba", "render", "ior.h")).read()
    table = hdr[hdr.index("ior_data[]"):hdr.index("nullptr")]
    iors = [(m.group(1), float(m.group(2)))
            for m in re.finditer(r'\{\s*"([^"]+)"\s*,\s*([0-9.eE+-]+)f?\s*\}', table)]
    assert len(iors) == 23, iors
    # Cross-check against Mitsuba itself: dielectric eta = int_ior / ext_ior.
    for name, val in iors:
        b = mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"})
        got = float(mi.traverse(b)["eta"])
        assert abs(got - val) < 1e-6, (name, got, val)

    # ---- conductors ----------------------------------------------------------
    names = sorted({f[:-len(".eta.spd")] for f in os.listdir(os.path.join(pkg, "data", "ior"))
                    if f.endswith(".eta.spd")}, key=lambda s: (s.lower(), s))
    conductors = []
    for name in ["none"] + names:
        b = mi.load_dict({"type": "conductor", "material": name})
        p = mi.traverse(b)
        eta = np.array(p["eta.value"], dtype=np.float64).reshape(-1)
        k = np.array(p["k.value"], dtype=np.float64).reshape(-1)
        if eta.size == 1:
            eta = np.repeat(eta, 3)
        if k.size == 1:
            k = np.repeat(k, 3)
        # Cross-check: reflectance at normal incidence sampled from Mitsuba.
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(0, 0, 1)
        si.n = mi.Vector3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        _, w = b.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5), True)
        w = np.array(w, dtype=np.float64).reshape(-1)
        with np.errstate(invalid="ignore"):
            ref = fresnel_conductor(1.0, eta, k)
        assert np.allclose(w, ref, rtol=1e-4, atol=1e-6, equal_nan=True), (name, w, ref)
        conductors.append((name, eta, k, w))

    # ---- emit Rust -------------------------------------------------------------
    o = []
    o.append("//! Named material presets, matching Mitsuba 3.9.1's `*_rgb` variants.")
    o.append("//!")
    o.append("//! GENERATED by `tools/dump_presets.py` from the installed Mitsuba 3.9.1")
    o.append("//! (`/work/.venv-mitsuba/bin/python tools/dump_presets.py`); do not edit by hand.")
    o.append("//!")
    o.append("//! * [`named_ior`]: Mitsuba's `ior_data` table (`src/render/ior.h`), used by")
    o.append("//!   `dielectric` `int_ior`/`ext_ior` given as strings. Mitsuba lower-cases the")
    o.append("//!   name before the lookup, so the match is case-insensitive. Note the")
    o.append("//!   dielectric defaults: `int_ior` = \"bk7\" (1.5046), `ext_ior` = \"air\"")
    o.append("//!   (1.000277), so a default dielectric has relative eta 1.5046/1.000277 = 1.50418.")
    o.append("//! * [`named_conductor`]: the RGB `(eta, k)` that the `*_rgb` variants use for a")
    o.append("//!   `conductor` `material`. Mitsuba converts the measured spectra in")
    o.append("//!   `data/ior/<name>.{eta,k}.spd` to unbounded sRGB once, at load time; these")
    o.append("//!   are those colours, read back with `mi.traverse`. Names are case-sensitive")
    o.append("//!   (they are file names). Fresnel is the exact conductor formula per channel.")
    o.append("//! * `none` (Mitsuba's default `material`): eta = 0, k = 1, i.e. the complex IOR")
    o.append("//!   is `i`, for which the conductor Fresnel reflectance is exactly 1 at every")
    o.append("//!   angle: a perfect, colourless 100 % mirror. (When `eta`/`k` are given")
    o.append("//!   explicitly, a missing `eta` defaults to 0 and a missing `k` to 1; giving")
    o.append("//!   `material` together with `eta`/`k` is an error in Mitsuba.)")
    zero = [n for n, e, k, _ in conductors if np.any((e == 0) & (k == 0))]
    if zero:
        o.append("//!")
        o.append("//! Caveat: Mitsuba clamps negative sRGB components to 0 when converting the")
        o.append("//! spectra, and for " + ", ".join(f"`{n}`" for n in zero) + " that leaves a channel with")
        o.append("//! eta = k = 0, where Mitsuba's conductor Fresnel term evaluates 0/0 = NaN")
        o.append("//! (the BSDF weight Mitsuba returns is NaN in that channel). Avoid those")
        o.append("//! materials in reference scenes.")
    o.append("")
    o.append("/// Names accepted by [`named_ior`] (lower case, as in Mitsuba's table).")
    o.append("pub const IOR_NAMES: &[&str] = &[")
    for name, _ in iors:
        o.append(f"    \"{name}\",")
    o.append("];")
    o.append("")
    o.append("/// Mitsuba 3's named index of refraction (`ior.h`), case-insensitive.")
    o.append("pub fn named_ior(name: &str) -> Option<f32> {")
    o.append("    let lower = name.to_ascii_lowercase();")
    o.append("    Some(match lower.as_str() {")
    for name, val in iors:
        o.append(f"        \"{name}\" => {f32_lit(val)},")
    o.append("        _ => return None,")
    o.append("    })")
    o.append("}")
    o.append("")
    o.append("/// Names accepted by [`named_conductor`] (case-sensitive, as in Mitsuba).")
    o.append("pub const CONDUCTOR_NAMES: &[&str] = &[")
    for name, *_ in conductors:
        o.append(f"    \"{name}\",")
    o.append("];")
    o.append("")
    o.append("/// RGB `(eta, k)` of a named `conductor` `material` in Mitsuba 3's `*_rgb`")
    o.append("/// variants. `\"none\"` is `([0; 3], [1; 3])`: a perfect mirror.")
    o.append("pub fn named_conductor(name: &str) -> Option<([f32; 3], [f32; 3])> {")
    o.append("    Some(match name {")
    for name, eta, k, w in conductors:
        e = ", ".join(f32_lit(x) for x in eta)
        kk = ", ".join(f32_lit(x) for x in k)
        r0 = ", ".join("NaN" if np.isnan(x) else f"{x:.4f}" for x in w)
        o.append(f"        // normal-incidence reflectance ({r0})")
        o.append(f"        \"{name}\" => ([{e}], [{kk}]),")
    o.append("        _ => return None,")
    o.append("    })")
    o.append("}")
    o.append("")
    o.append(TESTS)
    text = "\n".join(o)

    if args.check:
        old = open(args.out).read() if os.path.exists(args.out) else ""
        print("up to date" if old == text else "DIFFERS")
        sys.exit(0 if old == text else 1)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        f.write(text)
    print(f"wrote {args.out}: {len(iors)} IORs, {len(conductors)} conductors "
          f"(Mitsuba {mi.__version__})")
    for name, eta, k, w in conductors:
        if name in ("none", "Au", "Ag", "Al", "Cu", "Cr"):
            print(f"  {name:5s} eta={eta} k={k} R0={w}")


TESTS = r'''#[cfg(test)]
mod tests {
    use super::*;

    /// Exact unpolarised conductor Fresnel reflectance, complex IOR eta + i k.
    fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
        let c2 = cos_i * cos_i;
        let s2 = 1.0 - c2;
        let t0 = eta * eta - k * k - s2;
        let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
        let a = (0.5 * (a2b2 + t0)).sqrt();
        let t1 = a2b2 + c2;
        let t2 = 2.0 * cos_i * a;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = c2 * a2b2 + s2 * s2;
        let t4 = t2 * s2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        0.5 * (rp + rs)
    }

    #[test]
    fn ior_values() {
        assert_eq!(named_ior("bk7"), Some(1.5046));
        assert_eq!(named_ior("BK7"), Some(1.5046));
        assert_eq!(named_ior("water"), Some(1.333));
        assert_eq!(named_ior("air"), Some(1.000277));
        assert_eq!(named_ior("diamond"), Some(2.419));
        assert_eq!(named_ior("unobtainium"), None);
        assert_eq!(IOR_NAMES.len(), 23);
        for n in IOR_NAMES {
            assert!(named_ior(n).unwrap() >= 1.0);
        }
    }

    #[test]
    fn conductor_values() {
        let (eta, k) = named_conductor("Au").unwrap();
        assert!(k[0] > eta[0], "gold: k > eta in red");
        assert!(eta[2] > eta[0], "gold: eta larger in blue");
        assert!((eta[0] - 0.143).abs() < 1e-3 && (k[0] - 3.983).abs() < 1e-3);
        assert_eq!(named_conductor("au"), None, "names are case-sensitive");
        assert_eq!(named_conductor("none"), Some(([0.0; 3], [1.0; 3])));
        for n in CONDUCTOR_NAMES {
            assert!(named_conductor(n).is_some(), "{n}");
        }
    }

    #[test]
    fn none_is_a_perfect_mirror() {
        let (eta, k) = named_conductor("none").unwrap();
        for c in [1.0, 0.7, 0.3, 0.05] {
            let r = fresnel_conductor(c, eta[0] as f64, k[0] as f64);
            assert!((r - 1.0).abs() < 1e-9, "cos {c}: {r}");
        }
    }

    #[test]
    fn gold_is_yellow() {
        let (eta, k) = named_conductor("Au").unwrap();
        let r: Vec<f64> = (0..3)
            .map(|i| fresnel_conductor(1.0, eta[i] as f64, k[i] as f64))
            .collect();
        assert!(r[0] > r[1] && r[1] > r[2], "{r:?}");
    }
}
'''

if __name__ == "__main__":
    main()
