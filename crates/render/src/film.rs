//! Film: per-pixel weighted sums (Σ w·L and Σ w) and the reconstruction filter.
//!
//! Reconstruction uses filter importance sampling (Ernst et al. 2006): each
//! sample's image-plane offset is drawn from the filter itself, and the sample
//! contributes to its own pixel only, with weight f(x)/p(x). The estimate
//! Σ w L / Σ w converges to the same filtered image as Mitsuba's splatting,
//! while keeping pixels independent: the film stays additive, and the image is
//! identical whatever the thread count or tile order.

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
/// stay exact enough to merge and resume) and Σ w.
#[derive(Debug, Clone)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub sum: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        let n = (width * height) as usize;
        Film { width, height, sum: vec![[0.0; 3]; n], weight: vec![0.0; n] }
    }

    #[inline]
    pub fn add(&mut self, x: u32, y: u32, l: Spectrum, w: f32) {
        let i = (y * self.width + x) as usize;
        let s = &mut self.sum[i];
        s[0] += (l.x * w) as f64;
        s[1] += (l.y * w) as f64;
        s[2] += (l.z * w) as f64;
        self.weight[i] += w as f64;
    }

    /// Adds another film's sums (e.g. from another machine or pass).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (a, b) in self.weight.iter_mut().zip(&other.weight) {
            *a += *b;
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
