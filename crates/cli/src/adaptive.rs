//! Noise-based stopping (`--noise-threshold X`) and adaptive sampling
//! (`--adaptive`).
//!
//! The error estimate is the expected relMSE of the image against the
//! converged one, `penumbra diff`'s metric with the variance of each pixel's
//! mean standing in for its squared error:
//!
//!   E = 1/(3·P) Σ_pixels Σ_{c ∈ R,G,B} Var(mean_c) / (mean_c² + 0.01)
//!
//! (relMSE with ε = 0.01 as in Rousselle et al. 2011 and the denoising
//! literature; Var(mean) from the film's second moments, see
//! `Film::pixel_variance`). The render stops after the first pass at whose
//! end E ≤ X, once every pixel has [`MIN_SPP`] samples: with fewer, rare
//! bright paths are usually missing from a pixel's samples altogether and
//! its variance is underestimated (measured on the Cornell box: the estimate
//! at 4 spp was only twice that at 64 spp instead of sixteen times).
//!
//! Adaptive sampling follows Cycles' scheme: after a minimum number of
//! samples every pixel ([`MIN_SPP`]), a pass renders only the pixels whose
//! own error is still above X, and their 8 neighbours (Cycles dilates its
//! active mask the same way, so a pixel whose few samples happened to agree is
//! not stopped alone). The mask is a pure function of the film after the
//! previous pass, so a resumed render takes the same decisions and stays
//! bitwise identical; the film stays additive (pixels simply receive fewer
//! sample indices).

use penumbra_render::film::Film;

/// Samples every pixel receives before the error estimate is trusted:
/// before adaptive decisions start and before the noise threshold can stop.
pub const MIN_SPP: u32 = 16;

/// Whether the film (of `spp` samples per pixel) has at least [`MIN_SPP`]
/// and an estimated relMSE of at most `threshold`.
pub fn reached(film: &Film, spp: u32, threshold: f64) -> bool {
    spp >= MIN_SPP && film.rel_error().is_some_and(|e| e <= threshold)
}

/// The pixels the next pass renders, or None for all (before [`MIN_SPP`]).
pub fn active_pixels(film: &Film, spp: u32, threshold: f64) -> Option<Vec<bool>> {
    if spp < MIN_SPP || !film.has_variance() {
        return None;
    }
    let (w, h) = (film.width as usize, film.height as usize);
    let above: Vec<bool> = (0..w * h).map(|i| film.pixel_rel_error(i).unwrap() > threshold).collect();
    let mut active = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            if !above[y * w + x] {
                continue;
            }
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    active[yy * w + xx] = true;
                }
            }
        }
    }
    Some(active)
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_render::film::FilmLayers;
    use penumbra_render::math::Spectrum;

    #[test]
    fn mask_marks_noisy_pixels_and_their_neighbours() {
        let layers = FilmLayers { aovs: vec![], variance: true, ..Default::default() };
        let mut f = Film::with_layers(5, 4, &layers);
        for s in 0..16 {
            for y in 0..4 {
                for x in 0..5 {
                    // Pixel (3, 2) is noisy, all others constant.
                    let v = if (x, y) == (3, 2) { (s % 2) as f32 } else { 0.5 };
                    f.add(x, y, Spectrum::splat(v), 1.0);
                }
            }
        }
        assert!(active_pixels(&f, 8, 1e-3).is_none());
        let m = active_pixels(&f, 16, 1e-3).unwrap();
        let on: Vec<(usize, usize)> = (0..20).filter(|&i| m[i]).map(|i| (i % 5, i / 5)).collect();
        assert_eq!(on, [(2, 1), (3, 1), (4, 1), (2, 2), (3, 2), (4, 2), (2, 3), (3, 3), (4, 3)]);
        // Var of the mean of 16 samples of {0, 1}: (16/15)·0.25/16; relative to 0.25 + 0.01.
        let e = (16.0 / 15.0) * 0.25 / 16.0 / (0.25 + 0.01) / 20.0;
        assert!((f.rel_error().unwrap() - e).abs() < 1e-12);
        assert!(reached(&f, 16, e * 1.01) && !reached(&f, 16, e * 0.99) && !reached(&f, 8, e * 1.01));
    }
}
