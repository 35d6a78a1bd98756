//! Film: per-pixel weighted sums (Σ w·L and Σ w) and the reconstruction filter.
//!
//! Reconstruction uses filter importance sampling (Ernst et al. 2006): each
//! sample's image-plane offset is drawn from the filter itself, and the sample
//! contributes to its own pixel only, with weight f(x)/p(x). The estimate
//! Σ w L / Σ w converges to the same filtered image as Mitsuba's splatting,
//! while keeping pixels independent: the film stays additive, and the image is
//! identical whatever the thread count or tile order.

use crate::aov::{channel_count, AovKind};
use crate::math::Spectrum;
use glam::Vec2;

/// Mitsuba's reconstruction filters (`rfilter`), as 1D profiles applied
/// separably in x and y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterKind {
    /// `box`: 1 inside the pixel (radius 0.5).
    Box,
    /// `tent`: 1 - |x| / radius (default radius 1).
    Tent { radius: f32 },
    /// `gaussian`: exp(-x²/2σ²) - exp(-r²/2σ²) clamped at 0, with r = 4σ
    /// (default σ = 0.5).
    Gaussian { stddev: f32 },
}

const TABLE: usize = 64;

/// A 1D filter profile with a tabulated sampling distribution.
#[derive(Debug, Clone)]
pub struct Filter {
    pub kind: FilterKind,
    pub radius: f32,
    /// Piecewise-constant density over [-radius, radius]: CDF and densities.
    cdf: Vec<f32>,
    density: Vec<f32>,
}

impl Filter {
    pub fn new(kind: FilterKind) -> Filter {
        let radius = match kind {
            FilterKind::Box => 0.5,
            FilterKind::Tent { radius } => radius,
            FilterKind::Gaussian { stddev } => 4.0 * stddev,
        };
        let mut f = Filter { kind, radius, cdf: Vec::new(), density: Vec::new() };
        // Tabulate |f| at the bin midpoints; the sampling density need only
        // be positive where f is, the weight f/p corrects the rest exactly.
        let w = 2.0 * radius / TABLE as f32;
        let vals: Vec<f32> = (0..TABLE).map(|i| f.eval(-radius + (i as f32 + 0.5) * w).abs().max(1e-6)).collect();
        let total: f32 = vals.iter().sum::<f32>() * w;
        let mut acc = 0.0;
        f.cdf.push(0.0);
        for v in &vals {
            acc += v * w / total;
            f.cdf.push(acc);
            f.density.push(v / total);
        }
        *f.cdf.last_mut().unwrap() = 1.0;
        f
    }

    /// The 1D filter profile.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        match self.kind {
            FilterKind::Box => {
                if x.abs() <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            FilterKind::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            FilterKind::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                ((alpha * x * x).exp() - (alpha * self.radius * self.radius).exp()).max(0.0)
            }
        }
    }

    /// Samples an offset from the pixel centre; returns (offset, f/p).
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32) {
        if self.kind == FilterKind::Box {
            return (u - 0.5, 1.0);
        }
        let i = self.cdf[1..].partition_point(|&c| c <= u).min(TABLE - 1);
        let w = 2.0 * self.radius / TABLE as f32;
        let frac = ((u - self.cdf[i]) / (self.cdf[i + 1] - self.cdf[i])).clamp(0.0, 1.0);
        let x = -self.radius + (i as f32 + frac) * w;
        (x, self.eval(x) / self.density[i])
    }

    /// 2D separable sample: (offset, weight).
    #[inline]
    pub fn sample_2d(&self, u: Vec2) -> (Vec2, f32) {
        let (x, wx) = self.sample(u.x);
        let (y, wy) = self.sample(u.y);
        (Vec2::new(x, y), wx * wy)
    }
}

/// Additive image accumulator: per pixel Σ w·L (f64, so sums of many samples
/// stay exact enough to merge and resume) and Σ w; optionally the AOV sums
/// Σ w·a and the second moments the variance estimate needs. Every field is
/// a sum over samples, so films of disjoint sample sets simply add.
#[derive(Debug, Clone)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub sum: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
    /// The AOVs accumulated, in channel order (empty: none).
    pub aov_kinds: Vec<AovKind>,
    /// Σ w·a per pixel, `aov_channels()` values per pixel.
    pub aov: Vec<f64>,
    /// Per pixel [Σ w², Σ w²·L (R, G, B), Σ w²·L² (R, G, B)] when the
    /// variance is tracked (else empty).
    pub moments: Vec<[f64; 7]>,
}

/// Which layers a film accumulates besides the beauty.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FilmLayers {
    pub aovs: Vec<AovKind>,
    pub variance: bool,
}

/// ε of the relative error: relMSE = (a − b)² / (b² + ε), as `penumbra diff`.
pub const REL_EPS: f64 = 0.01;

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        Film::with_layers(width, height, &FilmLayers::default())
    }

    pub fn with_layers(width: u32, height: u32, layers: &FilmLayers) -> Film {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            sum: vec![[0.0; 3]; n],
            weight: vec![0.0; n],
            aov: vec![0.0; n * channel_count(&layers.aovs)],
            aov_kinds: layers.aovs.clone(),
            moments: if layers.variance { vec![[0.0; 7]; n] } else { Vec::new() },
        }
    }

    pub fn layers(&self) -> FilmLayers {
        FilmLayers { aovs: self.aov_kinds.clone(), variance: self.has_variance() }
    }

    /// AOV values per pixel.
    #[inline]
    pub fn aov_channels(&self) -> usize {
        channel_count(&self.aov_kinds)
    }

    #[inline]
    pub fn has_variance(&self) -> bool {
        !self.moments.is_empty()
    }

    #[inline]
    pub fn add(&mut self, x: u32, y: u32, l: Spectrum, w: f32) {
        let i = (y * self.width + x) as usize;
        let s = &mut self.sum[i];
        s[0] += (l.x * w) as f64;
        s[1] += (l.y * w) as f64;
        s[2] += (l.z * w) as f64;
        self.weight[i] += w as f64;
        if let Some(m) = self.moments.get_mut(i) {
            let w2 = w as f64 * w as f64;
            m[0] += w2;
            for (c, v) in l.to_array().into_iter().enumerate() {
                let v = v as f64;
                m[1 + c] += w2 * v;
                m[4 + c] += w2 * v * v;
            }
        }
    }

    /// Adds Σ w·a for a sample's AOV values `a` (`aov_channels()` of them).
    #[inline]
    pub fn add_aov(&mut self, x: u32, y: u32, a: &[f32], w: f32) {
        let n = self.aov_channels();
        let i = (y * self.width + x) as usize * n;
        for (acc, v) in self.aov[i..i + n].iter_mut().zip(a) {
            *acc += (v * w) as f64;
        }
    }

    /// Adds pixel `src` of `other` (same layers) to pixel `dst` of this film.
    #[inline]
    pub fn add_pixel(&mut self, dst: usize, other: &Film, src: usize) {
        for c in 0..3 {
            self.sum[dst][c] += other.sum[src][c];
        }
        self.weight[dst] += other.weight[src];
        let n = self.aov_channels();
        for k in 0..n {
            self.aov[dst * n + k] += other.aov[src * n + k];
        }
        if let Some(m) = self.moments.get_mut(dst) {
            for (a, b) in m.iter_mut().zip(&other.moments[src]) {
                *a += *b;
            }
        }
    }

    /// Adds another film's sums (e.g. from another machine or pass).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        assert_eq!(self.layers(), other.layers());
        for i in 0..self.weight.len() {
            self.add_pixel(i, other, i);
        }
    }

    /// The image: linear RGB, row-major, top row first.
    pub fn develop(&self) -> Vec<[f32; 3]> {
        self.sum
            .iter()
            .zip(&self.weight)
            .map(|(s, &w)| if w > 0.0 { [(s[0] / w) as f32, (s[1] / w) as f32, (s[2] / w) as f32] } else { [0.0; 3] })
            .collect()
    }

    /// One AOV's weighted means, `kind.channels().len()` values per pixel
    /// (None when the film does not accumulate it).
    pub fn develop_aov(&self, kind: AovKind) -> Option<Vec<f32>> {
        let mut off = 0;
        for k in &self.aov_kinds {
            if *k == kind {
                break;
            }
            off += k.channels().len();
        }
        if !self.aov_kinds.contains(&kind) {
            return None;
        }
        let (n, m) = (self.aov_channels(), kind.channels().len());
        let mut out = Vec::with_capacity(self.weight.len() * m);
        for (i, &w) in self.weight.iter().enumerate() {
            for c in 0..m {
                out.push(if w > 0.0 { (self.aov[i * n + off + c] / w) as f32 } else { 0.0 });
            }
        }
        Some(out)
    }

    /// Variance of pixel `i`'s mean, per channel (None without moments).
    ///
    /// The pixel value is the ratio estimator R = Σ wL / Σ w; its variance by
    /// the delta method (the standard error of a weighted mean) is
    /// Σ w² (L − R)² / (Σ w)², expanded into the stored moments, and scaled by
    /// n/(n − 1) with the effective sample count n = (Σ w)² / Σ w² (Kish), which
    /// makes it the unbiased s²/n for equal weights. Fewer than two effective
    /// samples: infinite.
    #[inline]
    pub fn pixel_variance(&self, i: usize) -> Option<[f64; 3]> {
        let m = self.moments.get(i)?;
        let w = self.weight[i];
        let n_eff = if m[0] > 0.0 { w * w / m[0] } else { 0.0 };
        if n_eff < 1.5 {
            return Some([f64::INFINITY; 3]);
        }
        let mut v = [0.0; 3];
        for c in 0..3 {
            let r = self.sum[i][c] / w;
            let s = m[4 + c] - 2.0 * r * m[1 + c] + r * r * m[0];
            v[c] = (s.max(0.0) / (w * w)) * n_eff / (n_eff - 1.0);
        }
        Some(v)
    }

    /// The variance of each pixel's mean (R, G, B), or None without moments.
    pub fn develop_variance(&self) -> Option<Vec<[f32; 3]>> {
        if !self.has_variance() {
            return None;
        }
        Some(
            (0..self.weight.len())
                .map(|i| self.pixel_variance(i).unwrap().map(|v| if v.is_finite() { v as f32 } else { f32::MAX }))
                .collect(),
        )
    }

    /// Estimated relative error of pixel `i`: the mean over R, G, B of
    /// Var[mean] / (mean² + ε), the expected relMSE of the pixel against the
    /// converged image (`penumbra diff`'s relMSE, with the variance of the
    /// mean standing in for the squared error).
    #[inline]
    pub fn pixel_rel_error(&self, i: usize) -> Option<f64> {
        let v = self.pixel_variance(i)?;
        let w = self.weight[i];
        let mut e = 0.0;
        for (c, vc) in v.iter().enumerate() {
            let r = if w > 0.0 { self.sum[i][c] / w } else { 0.0 };
            e += vc / (r * r + REL_EPS);
        }
        Some(e / 3.0)
    }

    /// The image's estimated relMSE: the mean of [`pixel_rel_error`](Self::pixel_rel_error)
    /// over all pixels (infinite while a pixel has fewer than two samples).
    pub fn rel_error(&self) -> Option<f64> {
        if !self.has_variance() {
            return None;
        }
        let n = self.weight.len().max(1) as f64;
        Some((0..self.weight.len()).map(|i| self.pixel_rel_error(i).unwrap()).sum::<f64>() / n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// E[f/p] over the sampling density equals ∫ f, and the weighted mean of
    /// a test function equals ∫ f g / ∫ f (the filtered value).
    #[test]
    fn filter_sampling_is_unbiased() {
        for kind in [FilterKind::Box, FilterKind::Tent { radius: 1.0 }, FilterKind::Gaussian { stddev: 0.5 }] {
            let f = Filter::new(kind);
            let n = 200_000;
            let (mut sw, mut swg) = (0.0f64, 0.0f64);
            for i in 0..n {
                let (x, w) = f.sample((i as f32 + 0.5) / n as f32);
                assert!(x.abs() <= f.radius + 1e-5);
                sw += w as f64;
                swg += (w * (x + 0.3).powi(2)) as f64;
            }
            // Reference by midpoint quadrature.
            let m = 100_000;
            let h = 2.0 * f.radius as f64 / m as f64;
            let (mut i_f, mut i_fg) = (0.0, 0.0);
            for k in 0..m {
                let x = -f.radius as f64 + (k as f64 + 0.5) * h;
                let fx = f.eval(x as f32) as f64;
                i_f += fx * h;
                i_fg += fx * (x + 0.3).powi(2) * h;
            }
            assert!((sw / n as f64 - i_f).abs() < 1e-3 * i_f, "{kind:?}");
            assert!((swg / sw - i_fg / i_f).abs() < 1e-3, "{kind:?}");
        }
    }
}
