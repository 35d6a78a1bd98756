//! pbrt-v4's spectra as the linear sRGB values an RGB renderer uses.
//!
//! pbrt-v4 renders spectrally; Penumbra converts each spectrum once, when
//! the scene loads, by its use (pbrt-v4's `SpectrumType`):
//!
//! - **Albedo** (reflectances): `rgb` as given (pbrt's `RGBAlbedoSpectrum`
//!   reproduces it under the D65 white); a list or `.spd` file integrated
//!   against the CIE 1931 curves under D65, clamped to [0, 1]; a constant is
//!   that grey.
//! - **Unbounded** (`eta`, `k`): as albedo, unclamped above. The named metal
//!   spectra (`metal-Cu-eta`, ...) are pbrt-v4's tables converted the same
//!   way (Mitsuba 3.9.1's `spectrum_list_to_srgb(bounded=false, d65=true)`
//!   over pbrt-v4's `src/pbrt/util/spectrum.cpp` data); the named glasses
//!   (`glass-BK7`, ...) are their index at 550 nm (an RGB renderer has no
//!   dispersion).
//! - **Illuminant** (light `L`, `I`): pbrt-v4 divides every light's scale
//!   by the spectrum's luminance (`SpectrumToPhotometric`), so a light is
//!   "1 nit" times `scale` whatever the spectrum's magnitude. An `rgb` value
//!   multiplies the colour space's illuminant (D65 for sRGB) and only the
//!   illuminant is normalised: `rgb L [r g b]` renders as (r, g, b). Any
//!   other spectrum (a list, a constant, a blackbody, a named illuminant)
//!   becomes its colour with luminance 1: a blackbody's colour at its
//!   temperature, `stdillum-D65` white.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

use super::super::params::SpectrumValue;
use crate::error::{FileLoc, LoadError, Result};
use crate::spectrum::{sampled_to_srgb, ColorUse};

/// How a spectrum is used (pbrt-v4's `SpectrumType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumUse {
    /// Reflectances in [0, 1].
    Albedo,
    /// Indices of refraction and absorption.
    Unbounded,
    /// Emission.
    Illuminant,
}

/// pbrt-v4's named metal spectra (η, k) as linear sRGB (see the module documentation).
#[allow(clippy::excessive_precision)]
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Ag", [0.128_347_3, 0.123_395_28, 0.150_713_88], [4.060_667, 3.282_512_2, 2.388_918_2]),
    ("Al", [1.405_951_1, 0.925_613_16, 0.583_375_99], [7.732_361, 6.595_023_6, 5.353_975]),
    ("Au", [0.079_870_72, 0.404_651_55, 1.558_967], [3.386_737, 2.500_704_5, 1.768_913]),
    ("Cu", [0.105_055_7, 0.976_817_37, 1.203_227_6], [3.270_152, 2.589_605_6, 2.366_341_8]),
    ("CuZn", [0.417_978_26, 0.519_506_3, 1.121_685], [3.663_861, 2.677_604_7, 1.769_291_5]),
    ("MgO", [1.731_913_2, 1.738_991_4, 1.751_446_9], [0.0, 0.0, 0.0]),
    ("TiO2", [2.857_481_2, 2.953_194_6, 3.181_715_5], [9.097e-5, 0.0, 5.663e-4]),
];

/// pbrt-v4's named glasses: the index at 550 nm, interpolated in its tables.
const GLASSES: &[(&str, f32)] = &[
    ("glass-BK7", 1.518_537),
    ("glass-BAF10", 1.673_051),
    ("glass-FK51A", 1.487_796),
    ("glass-LASF9", 1.855_809),
    ("glass-F5", 1.677_089),
    ("glass-F10", 1.733_574),
    ("glass-F11", 1.791_119),
];

/// The names [`named`] knows, for error messages.
fn known_names() -> String {
    let mut v: Vec<String> =
        METALS.iter().flat_map(|(m, _, _)| [format!("metal-{m}-eta"), format!("metal-{m}-k")]).collect();
    v.extend(GLASSES.iter().map(|(g, _)| g.to_string()));
    v.push("stdillum-D65".into());
    v.join(", ")
}

/// A named spectrum, if Penumbra knows it for this use.
fn named(name: &str, usage: SpectrumUse) -> Option<[f32; 3]> {
    if let Some(rest) = name.strip_prefix("metal-") {
        let (metal, part) = rest.rsplit_once('-')?;
        let (_, eta, k) = METALS.iter().find(|(m, _, _)| *m == metal)?;
        return match (part, usage) {
            ("eta", SpectrumUse::Unbounded) => Some(*eta),
            ("k", SpectrumUse::Unbounded) => Some(*k),
            _ => None,
        };
    }
    if let Some((_, eta)) = GLASSES.iter().find(|(g, _)| *g == name) {
        return (usage == SpectrumUse::Unbounded).then_some([*eta; 3]);
    }
    // D65 with luminance 1 is sRGB's white.
    (name == "stdillum-D65" && usage == SpectrumUse::Illuminant).then_some([1.0; 3])
}

/// Luminance of linear sRGB (the Y row of sRGB → XYZ).
fn luminance(c: [f64; 3]) -> f64 {
    0.212_639 * c[0] + 0.715_169 * c[1] + 0.072_192 * c[2]
}

/// A spectral power distribution as an illuminant's colour, normalised to
/// luminance 1 (pbrt-v4's photometric normalisation).
fn illuminant_colour(pairs: &[(f64, f64)], at: &FileLoc) -> Result<[f32; 3]> {
    let c = sampled_to_srgb(pairs, ColorUse::Emission);
    let y = luminance(c);
    if !(y > 0.0) {
        return Err(LoadError::at(at, "the emission spectrum has no luminance (it is zero over 360-830 nm)"));
    }
    Ok(c.map(|v| (v / y) as f32))
}

/// Planck's law (any constant factor: the colour is normalised), nm → relative radiance.
fn planck(nm: f64, t: f64) -> f64 {
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const KB: f64 = 1.380_649e-23;
    let l = nm * 1e-9;
    2.0 * H * C * C / (l.powi(5) * ((H * C / (l * KB * t)).exp() - 1.0))
}

/// `value` (given at `at`) as linear sRGB for `usage`.
pub fn to_rgb(value: &SpectrumValue, usage: SpectrumUse, at: &FileLoc) -> Result<[f32; 3]> {
    let rgb = match value {
        SpectrumValue::Rgb(c) => {
            if c.iter().any(|&v| v < 0.0) {
                return Err(LoadError::at(at, format!("rgb {c:?} has a negative component")));
            }
            if usage == SpectrumUse::Albedo && c.iter().any(|&v| v > 1.0) {
                return Err(LoadError::at(
                    at,
                    format!("rgb {c:?}: a reflectance above 1 (pbrt-v4 refuses it too); scale it into [0, 1]"),
                ));
            }
            c.map(|v| v as f32)
        }
        SpectrumValue::Blackbody(t) => {
            if usage != SpectrumUse::Illuminant {
                return Err(LoadError::at(at, "a blackbody spectrum is supported for light emission only"));
            }
            if !(*t > 0.0) {
                return Err(LoadError::at(at, format!("blackbody temperature {t} K must be positive")));
            }
            let pairs: Vec<(f64, f64)> = (360..=830).map(|nm| (nm as f64, planck(nm as f64, *t))).collect();
            illuminant_colour(&pairs, at)?
        }
        SpectrumValue::Constant(v) => {
            if *v < 0.0 {
                return Err(LoadError::at(at, format!("spectrum value {v} is negative")));
            }
            match usage {
                SpectrumUse::Illuminant => illuminant_colour(&[(360.0, 1.0), (830.0, 1.0)], at)?,
                SpectrumUse::Albedo if *v > 1.0 => {
                    return Err(LoadError::at(at, format!("a reflectance of {v} is above 1")))
                }
                _ => [*v as f32; 3],
            }
        }
        SpectrumValue::Samples(pairs) => match usage {
            SpectrumUse::Illuminant => illuminant_colour(pairs, at)?,
            SpectrumUse::Albedo => sampled_to_srgb(pairs, ColorUse::Reflectance).map(|v| v as f32),
            SpectrumUse::Unbounded => sampled_to_srgb(pairs, ColorUse::Unbounded).map(|v| v as f32),
        },
        SpectrumValue::Named(name) => match named(name, usage) {
            Some(c) => c,
            None => {
                let file = at.file.parent().map(|d| d.join(name)).filter(|p| p.is_file());
                let Some(path) = file else {
                    return Err(LoadError::at(
                        at,
                        format!(
                            "named spectrum \"{name}\" is not supported for {} (known: {}), and no such .spd file \
                             exists beside the scene; give an rgb value instead",
                            match usage {
                                SpectrumUse::Albedo => "a reflectance",
                                SpectrumUse::Unbounded => "an index of refraction",
                                SpectrumUse::Illuminant => "emission",
                            },
                            known_names()
                        ),
                    ));
                };
                let pairs = crate::spectrum::read_spd(&path).map_err(|e| LoadError::at(at, e))?;
                return to_rgb(&SpectrumValue::Samples(pairs), usage, at);
            }
        },
    };
    Ok(rgb)
}

/// A dielectric's index of refraction from a spectrum parameter: one
/// number (an RGB renderer has no dispersion).
pub fn eta(value: &SpectrumValue, at: &FileLoc) -> Result<f32> {
    let c = to_rgb(value, SpectrumUse::Unbounded, at)?;
    if (c[0] - c[1]).abs() > 1e-4 || (c[1] - c[2]).abs() > 1e-4 {
        // A varying spectrum: its value at the middle of the visible range.
        if let SpectrumValue::Samples(p) = value {
            let i = p.partition_point(|s| s.0 <= 550.0).clamp(1, p.len() - 1);
            let ((w0, v0), (w1, v1)) = (p[i - 1], p[i]);
            let t = ((550.0 - w0) / (w1 - w0)).clamp(0.0, 1.0);
            return Ok((v0 + t * (v1 - v0)) as f32);
        }
        return Err(LoadError::at(at, "a dielectric's eta must be one number (Penumbra renders no dispersion)"));
    }
    Ok(c[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn at() -> FileLoc {
        FileLoc::new(Arc::new("t.pbrt".into()), 1, 1)
    }

    #[test]
    fn illuminants_have_luminance_one_and_blackbodies_their_colour() {
        for t in [2000.0, 6504.0, 10000.0] {
            let c = to_rgb(&SpectrumValue::Blackbody(t), SpectrumUse::Illuminant, &at()).unwrap();
            let y = luminance(c.map(f64::from));
            assert!((y - 1.0).abs() < 1e-4, "{t}: {c:?}");
        }
        // Warm at 2000 K, blue at 10000 K, near white at D65's temperature.
        let warm = to_rgb(&SpectrumValue::Blackbody(2000.0), SpectrumUse::Illuminant, &at()).unwrap();
        assert!(warm[0] > 1.5 * warm[2], "{warm:?}");
        let cold = to_rgb(&SpectrumValue::Blackbody(10000.0), SpectrumUse::Illuminant, &at()).unwrap();
        assert!(cold[2] > 1.2 * cold[0], "{cold:?}");
        let white = to_rgb(&SpectrumValue::Blackbody(6504.0), SpectrumUse::Illuminant, &at()).unwrap();
        assert!(white.iter().all(|c| (c - 1.0).abs() < 0.12), "{white:?}");
        // rgb stays as given; a constant loses its magnitude.
        assert_eq!(
            to_rgb(&SpectrumValue::Rgb([2.0, 3.0, 4.0]), SpectrumUse::Illuminant, &at()).unwrap(),
            [2.0, 3.0, 4.0]
        );
        let a = to_rgb(&SpectrumValue::Constant(5.0), SpectrumUse::Illuminant, &at()).unwrap();
        assert!((luminance(a.map(f64::from)) - 1.0).abs() < 1e-4);
    }

    #[test]
    fn named_spectra_and_their_errors() {
        let cu = to_rgb(&SpectrumValue::Named("metal-Cu-k".into()), SpectrumUse::Unbounded, &at()).unwrap();
        assert!((cu[0] - 3.27).abs() < 0.01);
        assert!((eta(&SpectrumValue::Named("glass-BK7".into()), &at()).unwrap() - 1.5185).abs() < 1e-3);
        let e = to_rgb(&SpectrumValue::Named("metal-Xx-eta".into()), SpectrumUse::Unbounded, &at()).unwrap_err();
        assert!(e.to_string().contains("t.pbrt:1:1") && e.to_string().contains("metal-Cu-eta"), "{e}");
        let e = to_rgb(&SpectrumValue::Rgb([1.5, 0.0, 0.0]), SpectrumUse::Albedo, &at()).unwrap_err();
        assert!(e.to_string().contains("above 1"), "{e}");
    }
}
