//! The film's extra layers as EXR channels, and back.
//!
//! Every image gets its AOVs as layers of the one EXR part (`albedo.R/G/B`,
//! `normal.X/Y/Z`, `depth.Z`, `position.X/Y/Z`: weighted means, like the
//! beauty), the integrator's own output channels under Mitsuba's names
//! (the `aov` and `moment` integrators': `my_image.R`, `dd.y.T`,
//! `m2_my_image.X`, ...; weighted means too) and, with variance tracked, `variance.R/G/B` (the variance of the
//! pixel's mean). Parts (`--part`) also carry what `merge` needs to add the
//! second moments (`Film::moments`) without cancellation: Σ w² as
//! `penumbra.m0`, and per channel, centred on the stored pixel value r,
//! Σ w²(L − r) as `penumbra.m1.R/G/B` and Σ w²(L − r)² as `penumbra.m2.R/G/B`,
//! and Σ w³ as `penumbra.w3`;
//! each f64 split into two f32 channels (the value rounded to f32, and `.lo`
//! the rest), which keeps about 48 bits.

use crate::exrmeta::{ExrImage, WEIGHT_CHANNEL};
use anyhow::{bail, Result};
use penumbra_render::film::AovKind;
use penumbra_render::film::{Film, FilmLayers, MOMENTS};

/// What `--aov` names, besides the AOV kinds.
pub const VARIANCE: &str = "variance";

/// Parses `--aov albedo,normal,...` into film layers.
pub fn parse(list: &str) -> Result<FilmLayers> {
    let mut l = FilmLayers::default();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        if name == VARIANCE {
            l.variance = true;
        } else if let Some(k) = AovKind::from_name(name) {
            if !l.aovs.contains(&k) {
                l.aovs.push(k);
            }
        } else {
            bail!("--aov: unknown AOV '{name}'; supported: albedo, normal, depth, position, variance");
        }
    }
    // One canonical order, whatever order they were named in.
    l.aovs.sort_by_key(|k| AovKind::ALL.iter().position(|a| a == k));
    Ok(l)
}

/// The canonical text of a film's layers (for the settings).
pub fn describe(l: &FilmLayers) -> String {
    let mut names: Vec<&str> = l.aovs.iter().map(|k| k.name()).collect();
    if l.variance {
        names.push(VARIANCE);
    }
    names.join(",")
}

/// The moment channels ([`MOMENTS`]): Σ w², then Σ w²(L − r) and
/// Σ w²(L − r)² per channel, then Σ w³ (the camera samples'), then Σ s and
/// Σ s² per channel (the light paths' splats, stored as they are).
fn moment_name(k: usize) -> String {
    const RGB: [&str; 3] = ["R", "G", "B"];
    match k {
        0 => "penumbra.m0".into(),
        1..=3 => format!("penumbra.m1.{}", RGB[k - 1]),
        4..=6 => format!("penumbra.m2.{}", RGB[k - 4]),
        7 => "penumbra.w3".into(),
        8..=10 => format!("penumbra.s1.{}", RGB[k - 8]),
        _ => format!("penumbra.s2.{}", RGB[k - 11]),
    }
}

/// The EXR channels of `film`'s layers; with `part`, the raw moments too.
pub fn channels(film: &Film, part: bool) -> Vec<(String, Vec<f32>)> {
    let mut out = Vec::new();
    for &k in &film.aov_kinds {
        let v = film.develop_aov(k).unwrap();
        let m = k.channels().len();
        for (c, suffix) in k.channels().iter().enumerate() {
            out.push((format!("{}.{suffix}", k.name()), v.iter().skip(c).step_by(m).copied().collect()));
        }
    }
    for (c, name) in film.channels.iter().enumerate() {
        out.push((name.clone(), film.develop_channel(c)));
    }
    if let Some(v) = film.develop_variance() {
        for (c, suffix) in ["R", "G", "B"].iter().enumerate() {
            out.push((format!("{VARIANCE}.{suffix}"), v.iter().map(|p| p[c]).collect()));
        }
        if part {
            let rgb = film.develop();
            let centred: Vec<[f64; MOMENTS]> = film
                .moments
                .iter()
                .zip(&rgb)
                .map(|(m, p)| {
                    let mut c = *m;
                    for ch in 0..3 {
                        let r = p[ch] as f64;
                        c[1 + ch] = m[1 + ch] - r * m[0];
                        c[4 + ch] = m[4 + ch] - 2.0 * r * m[1 + ch] + r * r * m[0];
                    }
                    c
                })
                .collect();
            for k in 0..MOMENTS {
                let hi: Vec<f32> = centred.iter().map(|m| m[k] as f32).collect();
                let lo = centred.iter().zip(&hi).map(|(m, &h)| (m[k] - h as f64) as f32).collect();
                out.push((moment_name(k), hi));
                out.push((format!("{}.lo", moment_name(k)), lo));
            }
        }
    }
    out
}

/// The film of a part EXR (written with `channels(.., true)` and a weight
/// channel): Σ w·L = RGB·w, Σ w·a = a·w, moments from their channels.
pub fn film_of_part(img: &ExrImage, what: &str) -> Result<Film> {
    let Some(weight) = &img.weight else { bail!("'{what}' has no {WEIGHT_CHANNEL} channel") };
    let aovs: Vec<AovKind> = AovKind::ALL
        .into_iter()
        .filter(|k| img.layer(&format!("{}.{}", k.name(), k.channels()[0])).is_some())
        .collect();
    let variance = img.layer(&moment_name(0)).is_some();
    // The integrator's channels: every layer that is none of the above, in
    // the file's order.
    let known = |name: &str| {
        name.starts_with("penumbra.")
            || name.starts_with(&format!("{VARIANCE}."))
            || aovs.iter().any(|k| k.channels().iter().any(|c| name == format!("{}.{c}", k.name())))
    };
    let channels: Vec<String> = img.layers.iter().map(|(n, _)| n.clone()).filter(|n| !known(n)).collect();
    let layers = FilmLayers { aovs: aovs.clone(), variance, channels: channels.clone() };
    let mut film = Film::with_layers(img.width, img.height, &layers);
    let n = film.aov_channels();
    for (i, &w) in weight.iter().enumerate() {
        let w = w as f64;
        let [r, g, b] = img.rgb[i].map(|v| v as f64 * w);
        film.acc[i] = [r, g, b, w];
    }
    let mut off = 0;
    for k in &aovs {
        for suffix in k.channels() {
            let name = format!("{}.{suffix}", k.name());
            let Some(v) = img.layer(&name) else { bail!("'{what}' has no channel {name}") };
            for (i, &a) in v.iter().enumerate() {
                film.aov[i * n + off] = a as f64 * film.acc[i][3];
            }
            off += 1;
        }
    }
    for name in &channels {
        let v = img.layer(name).expect("listed above");
        for (i, &a) in v.iter().enumerate() {
            film.aov[i * n + off] = a as f64 * film.acc[i][3];
        }
        off += 1;
    }
    if variance {
        for k in 0..MOMENTS {
            let (Some(hi), Some(lo)) = (img.layer(&moment_name(k)), img.layer(&format!("{}.lo", moment_name(k))))
            else {
                bail!("'{what}' has no channel {}", moment_name(k))
            };
            for (i, m) in film.moments.iter_mut().enumerate() {
                m[k] = hi[i] as f64 + lo[i] as f64;
            }
        }
        // Back from moments centred on the stored value r to raw ones.
        for (m, p) in film.moments.iter_mut().zip(&img.rgb) {
            for ch in 0..3 {
                let (r, t, s) = (p[ch] as f64, m[1 + ch], m[4 + ch]);
                m[1 + ch] = t + r * m[0];
                m[4 + ch] = s + 2.0 * r * t + r * r * m[0];
            }
        }
    }
    Ok(film)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exrmeta::ExrImage;
    use penumbra_render::math::Spectrum;

    #[test]
    fn parts_round_trip_their_film() {
        let mut layers = parse("depth,variance,albedo").unwrap();
        assert_eq!(describe(&layers), "albedo,depth,variance");
        layers.channels = vec!["m2_a.X".into()];
        assert!(parse("albedo,velocity").unwrap_err().to_string().contains("velocity"));
        let mut f = Film::with_layers(2, 1, &layers);
        for s in 0..5 {
            f.add(1, 0, Spectrum::new(0.1 * s as f32, 0.3, 1.0 / 3.0), 0.7 + 0.01 * s as f32);
            f.add_aov(1, 0, &[0.5, 0.25, 0.125, 2.5, 4.0 + s as f32], 0.7 + 0.01 * s as f32);
        }
        let img = ExrImage {
            width: 2,
            height: 1,
            offset: (0, 0),
            full_size: (2, 1),
            rgb: f.develop(),
            weight: Some(f.acc.iter().map(|a| a[3] as f32).collect()),
            layers: channels(&f, true),
            meta: Default::default(),
        };
        let back = film_of_part(&img, "x").unwrap();
        assert_eq!(back.layers(), f.layers());
        let (a, b) = (f.pixel_variance(1).unwrap(), back.pixel_variance(1).unwrap());
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-5 * a[c].abs() + 1e-15, "{a:?} {b:?}");
        }
        assert!((back.develop_aov(AovKind::Depth).unwrap()[1] - 2.5).abs() < 1e-6);
        assert_eq!(back.develop_channel(0), f.develop_channel(0));
    }
}
