//! Spectra in the scene file, converted to linear sRGB as Mitsuba 3's RGB
//! variants (`scalar_rgb`, `llvm_ad_rgb`, ...) do when they load a scene.
//!
//! Mitsuba 3.9.1 (`Properties::get_texture_impl` in `src/core/properties.cpp`,
//! `spectrum_list_to_srgb` in `src/core/spectrum.cpp`) distinguishes three
//! uses of a colour parameter:
//!
//! - **Reflectance** (`get_texture`: BSDF reflectances, texture colours): a
//!   wavelength-sampled spectrum `s(λ)` is integrated against the CIE 1931
//!   colour matching functions *weighted by the D65 illuminant*,
//!   `XYZ = ∫ s(λ)·cmf(λ)·D65(λ) dλ` (D65 normalised to luminance 1), then
//!   converted to sRGB and **clamped to [0, 1]**. A unit reflectance thus
//!   gives white (≈ 1, 1, 1). A constant `<spectrum value="v"/>` is the grey `v`.
//! - **Unbounded** (`get_unbounded_texture`: conductor `eta`/`k`, roughness
//!   `alpha*`, hair `sigma_a`, polariser angles): as a reflectance (with D65),
//!   but only negative components are clamped (to 0).
//! - **Emission** (`get_emissive_texture`: `radiance`, `intensity`,
//!   `irradiance` of every emitter): integrated against the CIE curves
//!   *without* D65, `XYZ = ∫ s(λ)·cmf(λ) dλ`, so the spectrum is taken as an
//!   absolute power distribution; negative components are clamped to 0. A
//!   constant `<spectrum value="v"/>` becomes `v · xyz_to_srgb(1, 1, 1)`
//!   (an equal-energy spectrum, slightly purple in sRGB's D65 white point),
//!   whereas `<rgb value="v"/>` or `<float value="v"/>` stays grey.
//!
//! In every case the integral is Mitsuba's Riemann sum: 1000 wavelengths
//! evenly spaced over [360, 830] nm (both ends included), the spectrum
//! linearly interpolated between its samples and zero outside them, the
//! CIE and D65 tables (5 nm steps) linearly interpolated, and the sum
//! scaled by (830 − 360) / (1000 · 106.75025939941406).

use std::path::Path;

/// How a colour parameter is used, which decides its conversion (see the
/// module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorUse {
    /// With D65, clamped to [0, 1] (`get_texture`).
    Reflectance,
    /// With D65, negative components clamped to 0 (`get_unbounded_texture`).
    Unbounded,
    /// Without D65, negative components clamped to 0 (`get_emissive_texture`).
    Emission,
}

impl ColorUse {
    /// Mitsuba's choice for a parameter `name` of an object of `kind`:
    /// every emitter colour is emission (spot's `texture` excepted); the
    /// parameters Mitsuba reads with `get_unbounded_texture` are unbounded.
    pub fn of(kind: crate::desc::Kind, name: &str) -> ColorUse {
        const UNBOUNDED: &[&str] = &["eta", "k", "alpha", "alpha_u", "alpha_v", "sigma_a", "theta", "delta"];
        if kind == crate::desc::Kind::Emitter && name != "texture" {
            ColorUse::Emission
        } else if UNBOUNDED.contains(&name) {
            ColorUse::Unbounded
        } else {
            ColorUse::Reflectance
        }
    }
}

/// A constant spectrum `<spectrum value="v"/>` as linear sRGB.
pub fn constant_to_srgb(v: f64, usage: ColorUse) -> [f64; 3] {
    match usage {
        ColorUse::Emission => {
            // Mitsuba: `const_value * xyz_to_srgb(Color3f(1.0))` in single precision.
            let m = XYZ_TO_SRGB;
            let white = [0, 1, 2].map(|r| (m[r][0] + m[r][1] + m[r][2]) as f64);
            white.map(|c| v * c)
        }
        _ => [v; 3],
    }
}

/// A wavelength-sampled spectrum, (wavelength in nm, value) pairs with
/// increasing wavelengths, as linear sRGB (Mitsuba's
/// `spectrum_list_to_srgb(wavelengths, values, bounded, d65)`).
pub fn sampled_to_srgb(pairs: &[(f64, f64)], usage: ColorUse) -> [f64; 3] {
    let d65 = usage != ColorUse::Emission;
    let bounded = usage == ColorUse::Reflectance;
    let mut xyz = [0.0f64; 3];
    let (Some(first), Some(last)) = (pairs.first(), pairs.last()) else {
        return xyz;
    };
    const STEPS: usize = 1000;
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first.0 || w > last.0 {
            continue;
        }
        // The interval [index, index + 1] holding w (Mitsuba's find_interval).
        let index = pairs.partition_point(|p| p.0 <= w).saturating_sub(1).min(pairs.len().saturating_sub(2));
        let ((w0, v0), (w1, v1)) = (pairs[index], pairs[(index + 1).min(pairs.len() - 1)]);
        let v = if w0 == w1 { v0 } else { ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1) };
        let cmf = cie1931_xyz(w);
        let weight = v * if d65 { cie_d65(w) } else { 1.0 };
        for c in 0..3 {
            xyz[c] += cmf[c] * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / STEPS as f64;
    let xyz = xyz.map(|c| c * scale);
    let m = XYZ_TO_SRGB;
    let rgb = [0, 1, 2].map(|r| m[r][0] as f64 * xyz[0] + m[r][1] as f64 * xyz[1] + m[r][2] as f64 * xyz[2]);
    if bounded {
        rgb.map(|c| c.clamp(0.0, 1.0))
    } else {
        rgb.map(|c| c.max(0.0))
    }
}

/// Reads a spectrum file (`.spd`): one "wavelength value" pair per line,
/// lines starting with `#` are comments (Mitsuba's
/// `Properties::Spectrum(path)`). Wavelengths must increase, and there must
/// be at least two.
pub fn read_spd(path: &Path) -> Result<Vec<(f64, f64)>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read spectrum file: {e}"))?;
    parse_spd(bytes)
}

/// [`read_spd`] of a file's bytes.
pub fn parse_spd(bytes: Vec<u8>) -> Result<Vec<(f64, f64)>, String> {
    let text = crate::error::utf8_text(bytes).map_err(|e| format!("spectrum file is {e}"))?;
    let mut pairs = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut fields = line.split_whitespace().map(|t| t.trim_matches(',').parse::<f64>());
        match (fields.next(), fields.next()) {
            (Some(Ok(w)), Some(Ok(v))) if w.is_finite() && v.is_finite() => pairs.push((w, v)),
            (Some(Ok(_)), Some(Ok(_))) => {
                return Err(format!("line {}: \"{line}\" holds a number that is not finite", n + 1))
            }
            _ => return Err(format!("line {}: expected \"wavelength value\", found \"{line}\"", n + 1)),
        }
    }
    check_sampled(&pairs)?;
    Ok(pairs)
}

/// The rules Mitsuba checks for a sampled spectrum.
pub fn check_sampled(pairs: &[(f64, f64)]) -> Result<(), String> {
    if pairs.len() < 2 {
        return Err(format!("a sampled spectrum needs at least two wavelength:value pairs, got {}", pairs.len()));
    }
    if let Some((w, v)) = pairs.iter().find(|(w, v)| !(w.is_finite() && v.is_finite())) {
        return Err(format!(
            "the pair {w} nm: {v} is not finite (a spectrum's wavelengths and values must be finite numbers)"
        ));
    }
    if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
        return Err(format!(
            "wavelengths must be given in increasing order ({} nm is followed by {} nm)",
            w[0].0, w[1].0
        ));
    }
    Ok(())
}

/// Mitsuba's spectrum plugins (`<spectrum type="..." name="...">`), which
/// the XML reader turns into a plain property of the enclosing object, with
/// the meaning Mitsuba's RGB variants give them, or, where those refuse
/// (`blackbody`, `regular`, `irregular`), the meaning its spectral variants
/// give them, converted to RGB as every sampled spectrum is here:
///
/// | plugin      | parameters | becomes |
/// |-------------|------------|---------|
/// | `uniform`   | `value`, `wavelength_min`, `wavelength_max` | the constant `value` in every channel |
/// | `d65`       | `scale` (1), `color` | `color` · `scale` (white without `color`) |
/// | `srgb`      | `color`, `unbounded` (false: `color` must lie in [0, 1]) | `color` |
/// | `blackbody` | `temperature` (K), `wavelength_min` (360), `wavelength_max` (830) | Planck's law in W m⁻² sr⁻¹ nm⁻¹, sampled every nm |
/// | `regular`   | `wavelength_min`, `wavelength_max`, `values` | evenly spaced samples |
/// | `irregular` | `wavelengths`, `values` | samples at the given wavelengths |
pub const SPECTRUM_PLUGINS: &[&str] = &["uniform", "d65", "srgb", "blackbody", "regular", "irregular"];

/// The property value a spectrum plugin node stands for (see [`SPECTRUM_PLUGINS`]).
pub fn plugin_value(node: &crate::desc::Node) -> crate::error::Result<crate::desc::Value> {
    use crate::desc::Value;
    use crate::error::LoadError;
    let numbers = |name: &str| -> crate::error::Result<Vec<f64>> {
        let (text, loc) =
            node.get_string(name)?.ok_or_else(|| node.error(format!("spectrum '{}' needs '{name}'", node.plugin)))?;
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| LoadError::at(&loc, format!("'{s}' in {name} is not a finite number")))
            })
            .collect()
    };
    // (The XML reader already refuses non-finite numbers in every colour.)
    let rgb = |name: &str| node.get_rgb(name);
    let range = |lo: f64, hi: f64| -> crate::error::Result<(f64, f64)> {
        let (a, b) = (node.float("wavelength_min", lo)?, node.float("wavelength_max", hi)?);
        if !(a.is_finite() && b.is_finite() && a < b) {
            return Err(node.error(format!("wavelength_min {a} must be smaller than wavelength_max {b}")));
        }
        Ok((a, b))
    };
    let sampled = |pairs: Vec<(f64, f64)>| -> crate::error::Result<Value> {
        check_sampled(&pairs).map_err(|m| node.error(format!("spectrum '{}': {m}", node.plugin)))?;
        Ok(Value::SpectrumSampled(pairs))
    };
    let value = match node.plugin.as_str() {
        "uniform" => {
            let v = node.get_float("value")?.ok_or_else(|| node.error("spectrum 'uniform' needs 'value'"))?;
            range(360.0, 830.0)?;
            Value::Rgb([v; 3])
        }
        "d65" => {
            let scale = node.float("scale", 1.0)?;
            let c = rgb("color")?.unwrap_or([1.0; 3]);
            Value::Rgb(c.map(|x| x * scale))
        }
        "srgb" => {
            let c = rgb("color")?.ok_or_else(|| node.error("spectrum 'srgb' needs 'color'"))?;
            if !node.bool("unbounded", false)? && c.iter().any(|&x| !(0.0..=1.0).contains(&x)) {
                return Err(LoadError::at(
                    node.loc_of("color"),
                    "color must lie in [0, 1] (as Mitsuba requires), or set 'unbounded' to true",
                ));
            }
            Value::Rgb(c)
        }
        "blackbody" => {
            let t =
                node.get_float("temperature")?.ok_or_else(|| node.error("spectrum 'blackbody' needs 'temperature'"))?;
            if !(t.is_finite() && t > 0.0) {
                return Err(LoadError::at(node.loc_of("temperature"), format!("temperature {t} K must be positive")));
            }
            let (lo, hi) = range(360.0, 830.0)?;
            // Planck's law in W m⁻² sr⁻¹ nm⁻¹ (Mitsuba's blackbody.cpp constants).
            let (c, h, k) = (2.99792458e8f64, 6.62607004e-34f64, 1.38064852e-23f64);
            let planck = |nm: f64| {
                let l = nm * 1e-9;
                1e-9 * 2.0 * h * c * c / (l.powi(5) * ((h * c / (k * l * t)).exp() - 1.0))
            };
            // One sample per nm: a range of more than 10^5 nm would allocate without bound.
            if hi - lo > 1e5 {
                return Err(node.error(format!(
                    "spectrum 'blackbody': the range {lo} to {hi} nm would take {} samples (one per nm); \
                     at most 100000 are allowed",
                    (hi - lo).ceil()
                )));
            }
            let n = ((hi - lo).ceil() as usize).max(1);
            sampled((0..=n).map(|i| lo + (hi - lo) * i as f64 / n as f64).map(|l| (l, planck(l))).collect())?
        }
        "regular" => {
            if !(node.has("wavelength_min") && node.has("wavelength_max")) {
                return Err(node.error("spectrum 'regular' needs 'wavelength_min' and 'wavelength_max'"));
            }
            let (lo, hi) = range(f64::NAN, f64::NAN)?;
            let values = numbers("values")?;
            if values.len() < 2 {
                return Err(node.error("spectrum 'regular' needs at least two values"));
            }
            let n = values.len() - 1;
            sampled(values.iter().enumerate().map(|(i, &v)| (lo + (hi - lo) * i as f64 / n as f64, v)).collect())?
        }
        "irregular" => {
            let (w, v) = (numbers("wavelengths")?, numbers("values")?);
            if w.len() != v.len() {
                return Err(node.error(format!("{} wavelengths but {} values", w.len(), v.len())));
            }
            sampled(w.into_iter().zip(v).collect())?
        }
        other => return Err(node.error(format!("'{other}' is not a spectrum plugin"))),
    };
    node.check_all_used(&[])?;
    Ok(value)
}

const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;
/// Makes a unit spectrum integrate to luminance 1 (Mitsuba's constants, digit for digit).
#[allow(clippy::excessive_precision)]
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.7502593994140625;
/// Makes the D65 table integrate to luminance 1.
#[allow(clippy::excessive_precision)]
const CIE_D65_NORMALIZATION: f64 = 1.0 / 98.99741751876255;

/// XYZ → linear sRGB (ITU-R BT.709), in single precision as in Mitsuba.
#[allow(clippy::excessive_precision)]
const XYZ_TO_SRGB: [[f32; 3]; 3] =
    [[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]];

/// Position in the 5 nm tables: (lower index, weight of the upper one), or
/// `None` outside [360, 830] nm.
fn table_pos(w: f64) -> Option<(usize, f64)> {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return None;
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    Some((i0, t - i0 as f64))
}

fn lerp_table(table: &[f32; CIE_SAMPLES], i0: usize, w1: f64) -> f64 {
    (1.0 - w1) * table[i0] as f64 + w1 * table[i0 + 1] as f64
}

/// The CIE 1931 2° colour matching functions at `w` nm.
pub(crate) fn cie1931_xyz(w: f64) -> [f64; 3] {
    match table_pos(w) {
        Some((i0, w1)) => [lerp_table(&CIE_X, i0, w1), lerp_table(&CIE_Y, i0, w1), lerp_table(&CIE_Z, i0, w1)],
        None => [0.0; 3],
    }
}

/// The D65 illuminant at `w` nm, normalised to luminance 1.
fn cie_d65(w: f64) -> f64 {
    match table_pos(w) {
        Some((i0, w1)) => lerp_table(&D65, i0, w1) * CIE_D65_NORMALIZATION,
        None => 0.0,
    }
}

// Tables from Mitsuba 3.9.1 (`src/core/spectrum.cpp`, `include/mitsuba/core/spectrum.h`):
// CIE 1931 2° observer and the CIE D65 illuminant, 360..830 nm in 5 nm steps.
const CIE_X: [f32; 95] = [
    0.0001299,
    0.0002321,
    0.0004149,
    0.0007416,
    0.001368,
    0.002236,
    0.004243,
    0.00765,
    0.01431,
    0.02319,
    0.04351,
    0.07763,
    0.13438,
    0.21477,
    0.2839,
    0.3285,
    0.34828,
    0.34806,
    0.3362,
    0.3187,
    0.2908,
    0.2511,
    0.19536,
    0.1421,
    0.09564,
    0.05795001,
    0.03201,
    0.0147,
    0.0049,
    0.0024,
    0.0093,
    0.0291,
    0.06327,
    0.1096,
    0.1655,
    0.2257499,
    0.2904,
    0.3597,
    0.4334499,
    0.5120501,
    0.5945,
    0.6784,
    0.7621,
    0.8425,
    0.9163,
    0.9786,
    1.0263,
    1.0567,
    1.0622,
    1.0456,
    1.0026,
    0.9384,
    0.8544499,
    0.7514,
    0.6424,
    0.5419,
    0.4479,
    0.3608,
    0.2835,
    0.2187,
    0.1649,
    0.1212,
    0.0874,
    0.0636,
    0.04677,
    0.0329,
    0.0227,
    0.01584,
    0.01135916,
    0.008110916,
    0.005790346,
    0.004109457,
    0.002899327,
    0.00204919,
    0.001439971,
    0.0009999493,
    0.0006900786,
    0.0004760213,
    0.0003323011,
    0.0002348261,
    0.0001661505,
    0.000117413,
    0.00008307527,
    0.00005870652,
    0.00004150994,
    0.00002935326,
    0.00002067383,
    0.00001455977,
    0.00001025398,
    0.000007221456,
    0.000005085868,
    0.000003581652,
    0.000002522525,
    0.000001776509,
    0.000001251141,
];
const CIE_Y: [f32; 95] = [
    0.000003917,
    0.000006965,
    0.00001239,
    0.00002202,
    0.000039,
    0.000064,
    0.00012,
    0.000217,
    0.000396,
    0.00064,
    0.00121,
    0.00218,
    0.004,
    0.0073,
    0.0116,
    0.01684,
    0.023,
    0.0298,
    0.038,
    0.048,
    0.06,
    0.0739,
    0.09098,
    0.1126,
    0.13902,
    0.1693,
    0.20802,
    0.2586,
    0.323,
    0.4073,
    0.503,
    0.6082,
    0.71,
    0.7932,
    0.862,
    0.9148501,
    0.954,
    0.9803,
    0.9949501,
    1.0,
    0.995,
    0.9786,
    0.952,
    0.9154,
    0.87,
    0.8163,
    0.757,
    0.6949,
    0.631,
    0.5668,
    0.503,
    0.4412,
    0.381,
    0.321,
    0.265,
    0.217,
    0.175,
    0.1382,
    0.107,
    0.0816,
    0.061,
    0.04458,
    0.032,
    0.0232,
    0.017,
    0.01192,
    0.00821,
    0.005723,
    0.004102,
    0.002929,
    0.002091,
    0.001484,
    0.001047,
    0.00074,
    0.00052,
    0.0003611,
    0.0002492,
    0.0001719,
    0.00012,
    0.0000848,
    0.00006,
    0.0000424,
    0.00003,
    0.0000212,
    0.00001499,
    0.0000106,
    0.0000074657,
    0.0000052578,
    0.0000037029,
    0.0000026078,
    0.0000018366,
    0.0000012934,
    0.00000091093,
    0.00000064153,
    0.00000045181,
];
const CIE_Z: [f32; 95] = [
    0.0006061,
    0.001086,
    0.001946,
    0.003486,
    0.006450001,
    0.01054999,
    0.02005001,
    0.03621,
    0.06785001,
    0.1102,
    0.2074,
    0.3713,
    0.6456,
    1.0390501,
    1.3856,
    1.62296,
    1.74706,
    1.7826,
    1.77211,
    1.7441,
    1.6692,
    1.5281,
    1.28764,
    1.0419,
    0.8129501,
    0.6162,
    0.46518,
    0.3533,
    0.272,
    0.2123,
    0.1582,
    0.1117,
    0.07824999,
    0.05725001,
    0.04216,
    0.02984,
    0.0203,
    0.0134,
    0.008749999,
    0.005749999,
    0.0039,
    0.002749999,
    0.0021,
    0.0018,
    0.001650001,
    0.0014,
    0.0011,
    0.001,
    0.0008,
    0.0006,
    0.00034,
    0.00024,
    0.00019,
    0.0001,
    0.00004999999,
    0.00003,
    0.00002,
    0.00001,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
];
const D65: [f32; 95] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204, 91.486, 92.4589, 93.4318,
    90.057, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41, 117.812, 116.336, 114.861, 115.392, 115.923, 112.367,
    108.811, 109.082, 109.354, 108.578, 107.802, 106.296, 104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046,
    102.023, 100.0, 98.1671, 96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489,
    87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281, 78.2842,
    74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765, 61.604, 65.7448, 69.8856, 72.4863, 75.087, 69.3398,
    63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959,
    54.6998, 57.4406, 58.8765, 60.3125,
];
