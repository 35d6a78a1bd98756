//! Film: per-pixel weighted sums (Σ w·L and Σ w) and the reconstruction filter.
//!
//! Reconstruction splats as Mitsuba 3's `ImageBlock` does: a sample at film
//! position p (pixel + uniform offset) adds f(p - c)·L and f(p - c) to every
//! pixel whose centre c lies within the filter's radius, and a pixel's value
//! is Σ w·L / Σ w. Each pixel thus averages the samples of its neighbours
//! too, which for Mitsuba's default Gaussian has about a third of the
//! per-pixel variance of giving each sample to its own pixel only (filter
//! importance sampling) at the same sample count. The film stays additive;
//! tiles render into films with a margin of the filter's reach and are added
//! in a fixed order, so the image does not depend on the thread count.

pub mod aov;

use crate::math::{fast, Spectrum};
pub use aov::{channel_count, AovKind, AovSample};
use glam::Vec2;

/// Mitsuba's reconstruction filters (`rfilter`), as 1D profiles applied
/// separably in x and y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterKind {
    /// `box`: 1 inside the pixel (radius 0.5).
    Box,
    /// `tent`: 1 - |x| / radius (default radius 1).
    Tent {
        /// Support radius in pixels.
        radius: f32,
    },
    /// `gaussian`: exp(-x²/2σ²) - exp(-r²/2σ²) clamped at 0, with r = 4σ
    /// (default σ = 0.5).
    Gaussian {
        /// Standard deviation σ in pixels.
        stddev: f32,
    },
    /// `mitchell`: the Mitchell–Netravali cubic (1988) with parameters B
    /// and C (default 1/3 each), radius 2; negative lobes.
    Mitchell {
        /// Blur parameter B.
        b: f32,
        /// Ringing parameter C.
        c: f32,
    },
    /// `catmullrom`: the Mitchell–Netravali cubic with B = 0, C = 1/2.
    CatmullRom,
    /// `lanczos`: sinc(x) · sinc(x / lobes) within |x| < lobes (default 3).
    Lanczos {
        /// Lobes on each side; also the radius in pixels.
        lobes: u32,
    },
}

/// The Mitchell–Netravali cubic with parameters (B, C) at |x| (radius 2),
/// in Mitsuba's form (src/rfilters/mitchell.cpp).
#[inline]
fn mitchell(x: f32, b: f32, c: f32) -> f32 {
    let x = x.abs();
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else {
        (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)
    };
    if x < 2.0 {
        v / 6.0
    } else {
        0.0
    }
}

/// The widest margin (in pixels) a filter may reach beyond its pixel.
pub const MAX_MARGIN: u32 = 16;

/// A 1D filter profile.
#[derive(Debug, Clone)]
pub struct Filter {
    /// The profile's shape.
    pub kind: FilterKind,
    /// Support radius in pixels (the profile is 0 beyond it).
    pub radius: f32,
    /// The Gaussian tabulated on [0, radius] (`TABLE` intervals), for
    /// splatting: ten profile evaluations per sample are otherwise ten
    /// `exp` calls, a third of a sample's time in light scenes.
    table: Vec<f32>,
    inv_step: f32,
}

/// Intervals of the tabulated profile; linear interpolation between them
/// is within 2e-6 of the Gaussian (relative to its peak).
const TABLE: usize = 1024;
/// The table's length with its zero padding: index ⌊2.5 · TABLE / 1.5⌋ + 1.
const TABLE_PADDED: usize = TABLE * 5 / 3 + 3;

impl Filter {
    /// The filter of a kind, tabulated when Gaussian.
    pub fn new(kind: FilterKind) -> Filter {
        let radius = match kind {
            FilterKind::Box => 0.5,
            FilterKind::Tent { radius } => radius,
            FilterKind::Gaussian { stddev } => 4.0 * stddev,
            FilterKind::Mitchell { .. } | FilterKind::CatmullRom => 2.0,
            FilterKind::Lanczos { lobes } => lobes as f32,
        };
        let mut f = Filter { kind, radius, table: Vec::new(), inv_step: TABLE as f32 / radius };
        if let FilterKind::Gaussian { .. } = kind {
            f.table = (0..=TABLE).map(|i| f.eval(radius * i as f32 / TABLE as f32)).collect();
            // Zeros past the radius, up to the farthest tap of a margin-2
            // footprint (|x| ≤ 2.5, radius > 1.5), so `taps` needs no test.
            f.table.resize(TABLE_PADDED, 0.0);
        }
        f
    }

    /// The profile as splatting uses it: exact for box and tent, the
    /// interpolated table for the Gaussian.
    #[inline]
    pub fn weight(&self, x: f32) -> f32 {
        if self.table.is_empty() {
            return self.eval(x);
        }
        let t = x.abs() * self.inv_step;
        let i = fast::index(t);
        if i >= TABLE {
            return 0.0;
        }
        let f = t - i as f32;
        self.table[i] + f * (self.table[i + 1] - self.table[i])
    }

    /// The weights of a footprint's `N` = 2m + 1 taps along one axis, at
    /// distances `u + m − k − 1/2` (k = 0..N) for `u` in [0, 1]: bitwise
    /// [`Self::weight`] of each, without its tests for the tabulated
    /// Gaussian of margin 2 (the padded table returns the zeros the test
    /// would).
    #[inline(always)]
    fn taps<const N: usize>(&self, u: f32) -> [f32; N] {
        let m = (N / 2) as i32;
        let x: [f32; N] = std::array::from_fn(|k| u + (m - k as i32) as f32 - 0.5);
        // Box and tent: `eval`'s expressions, with the match taken once
        // per sample rather than once per tap.
        match self.kind {
            FilterKind::Box => return std::array::from_fn(|k| if x[k].abs() <= 0.5 { 1.0 } else { 0.0 }),
            FilterKind::Tent { radius } => return std::array::from_fn(|k| (1.0 - x[k].abs() / radius).max(0.0)),
            _ => {}
        }
        if N != 5 || self.table.len() != TABLE_PADDED || !(0.0..=1.0).contains(&u) {
            return std::array::from_fn(|k| self.weight(x[k]));
        }
        let table: &[f32; TABLE_PADDED] = self.table[..].try_into().unwrap();
        std::array::from_fn(|k| {
            let x = x[k];
            // |x| ≤ 2.5 and radius > 1.5 (margin 2): 0 ≤ t < TABLE_PADDED − 2.
            let t = x.abs() * self.inv_step;
            debug_assert!((0.0..(TABLE_PADDED - 2) as f32).contains(&t));
            // SAFETY: t is finite and in [0, 2^31) (above), where the
            // truncation is exact; `as i32` would add NaN and range tests.
            let i = unsafe { t.to_int_unchecked::<i32>() } as usize;
            let i = i.min(TABLE_PADDED - 2);
            let f = t - i as f32;
            table[i] + f * (table[i + 1] - table[i])
        })
    }

    /// How many pixels beyond its own a sample can reach: ceil(radius - 1/2).
    pub fn margin(&self) -> u32 {
        (self.radius - 0.5).max(0.0).ceil() as u32
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
            FilterKind::Mitchell { b, c } => mitchell(x, b, c),
            FilterKind::CatmullRom => mitchell(x, 0.0, 0.5),
            FilterKind::Lanczos { lobes } => {
                let x = x.abs();
                let r = lobes as f32;
                if x < f32::EPSILON {
                    1.0
                } else if x > r {
                    0.0
                } else {
                    let x1 = crate::math::PI * x;
                    let x2 = x1 / r;
                    (x1.sin() * x2.sin()) / (x1 * x2)
                }
            }
        }
    }
}

/// `acc += v`, each f32 lane widened to f64: one `vcvtps2pd` and one
/// `vaddpd` with AVX, the same IEEE operations lane by lane as the scalar
/// form (so both give the same bits).
#[inline(always)]
fn add_widened(acc: &mut [f64; 4], v: glam::Vec4) {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    // SAFETY: AVX is enabled at compile time; `acc` is 4 f64 (unaligned
    // loads and stores), `v` 4 f32.
    unsafe {
        use std::arch::x86_64::*;
        let p = acc.as_mut_ptr();
        let wide = _mm256_cvtps_pd(_mm_loadu_ps(v.as_ref().as_ptr()));
        _mm256_storeu_pd(p, _mm256_add_pd(_mm256_loadu_pd(p), wide));
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
    for (a, c) in acc.iter_mut().zip(v.to_array()) {
        *a += c as f64;
    }
}

/// The taps k (pixel `first + k`) whose pixel lies in [0, size) and whose
/// weight is not zero, trimmed from both ends (where a filter's profile
/// runs out).
#[inline]
fn nonzero_taps(w: &[f32], first: i32, size: u32) -> std::ops::Range<usize> {
    let mut lo = (-first).max(0) as usize;
    let mut hi = (size as i32 - first).clamp(0, w.len() as i32) as usize;
    while lo < hi && w[lo] == 0.0 {
        lo += 1;
    }
    while hi > lo && w[hi - 1] == 0.0 {
        hi -= 1;
    }
    lo..hi
}

/// Additive image accumulator: per pixel Σ w·L (f64, so sums of many samples
/// stay exact enough to merge and resume) and Σ w; optionally the AOV sums
/// Σ w·a and the second moments the variance estimate needs. Every field is
/// a sum over samples, so films of disjoint sample sets simply add.
#[derive(Debug, Clone)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per pixel [Σ w·R, Σ w·G, Σ w·B, Σ w], interleaved so that a splat
    /// adds one 4-wide vector per pixel.
    pub acc: Vec<[f64; 4]>,
    /// The AOVs accumulated, in channel order (empty: none).
    pub aov_kinds: Vec<AovKind>,
    /// The integrator's own output channels (Mitsuba's `aov_names()`, e.g.
    /// `dd.y.T` of the `aov` integrator), stored after the AOV kinds' channels.
    pub channels: Vec<String>,
    /// Σ w·a per pixel, `aov_channels()` values per pixel.
    pub aov: Vec<f64>,
    /// Per pixel [Σ w², Σ w²·L (R, G, B), Σ w²·L² (R, G, B), Σ w³] of the
    /// camera samples, then [Σ s (R, G, B), Σ s² (R, G, B)] of the values s
    /// that light paths added to Σ w·L ([`Self::splat_radiance`]), when the
    /// variance is tracked (else empty).
    pub moments: Vec<[f64; MOMENTS]>,
}

/// Which layers a film accumulates besides the beauty.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FilmLayers {
    /// AOVs accumulated, in channel order.
    pub aovs: Vec<AovKind>,
    /// Whether the second moments for the variance estimate are tracked.
    pub variance: bool,
    /// The integrator's output channels (see [`Film::channels`]).
    pub channels: Vec<String>,
}

/// Moments per pixel of [`Film::moments`].
pub const MOMENTS: usize = 14;
/// Where the light paths' Σ s and Σ s² start in [`Film::moments`].
const SPLAT_SUM: usize = 8;
const SPLAT_SQUARES: usize = 11;

/// ε of the relative error: relMSE = (a − b)² / (b² + ε), as `penumbra diff`.
pub const REL_EPS: f64 = 0.01;

impl Film {
    /// An empty film with the beauty only.
    pub fn new(width: u32, height: u32) -> Film {
        Film::with_layers(width, height, &FilmLayers::default())
    }

    /// An empty film accumulating `layers`.
    pub fn with_layers(width: u32, height: u32, layers: &FilmLayers) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            acc: vec![[0.0; 4]; n],
            aov: vec![0.0; n * (channel_count(&layers.aovs) + layers.channels.len())],
            aov_kinds: layers.aovs.clone(),
            channels: layers.channels.clone(),
            moments: if layers.variance { vec![[0.0; MOMENTS]; n] } else { Vec::new() },
        }
    }

    /// The layers this film accumulates.
    pub fn layers(&self) -> FilmLayers {
        FilmLayers { aovs: self.aov_kinds.clone(), variance: self.has_variance(), channels: self.channels.clone() }
    }

    /// AOV values per pixel: the AOV kinds' channels, then the integrator's.
    #[inline]
    pub fn aov_channels(&self) -> usize {
        channel_count(&self.aov_kinds) + self.channels.len()
    }

    /// Whether the second moments are tracked.
    #[inline]
    pub fn has_variance(&self) -> bool {
        !self.moments.is_empty()
    }

    /// Adds radiance `l` with filter weight `w` to pixel (x, y).
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, l: Spectrum, w: f32) {
        let i = (y * self.width + x) as usize;
        let s = &mut self.acc[i];
        s[0] += (l.x * w) as f64;
        s[1] += (l.y * w) as f64;
        s[2] += (l.z * w) as f64;
        s[3] += w as f64;
        if let Some(m) = self.moments.get_mut(i) {
            let w2 = w as f64 * w as f64;
            m[0] += w2;
            m[7] += w2 * w as f64;
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
        for c in 0..4 {
            self.acc[dst][c] += other.acc[src][c];
        }
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

    /// Splats a sample taken at offset `u` ∈ [0, 1)² within pixel (`px`,
    /// `py`) into every pixel of this film within the filter's radius. The
    /// weights depend only on `u` and pixel distances, not on where the
    /// film lies in the image, so tiles and crops weigh a sample alike.
    /// `aov`: the sample's AOV values, splatted with the same weights.
    #[inline]
    pub fn splat(&mut self, px: i32, py: i32, u: Vec2, l: Spectrum, aov: Option<&[f32]>, filter: &Filter) {
        // Weight arrays sized for the filter: zeroing 2 × 33 taps for a
        // Gaussian that uses 5 cost more than splatting its pixels.
        if filter.margin() <= 2 {
            self.splat_taps::<5>(px, py, u, l, aov, filter)
        } else {
            self.splat_taps::<{ 2 * MAX_MARGIN as usize + 1 }>(px, py, u, l, aov, filter)
        }
    }

    /// Splats the samples of one pixel, in order, as [`Self::splat`] of
    /// each with no AOVs would: `samples` are (position in the pixel,
    /// radiance), non-finite radiance is skipped by the caller. Where the
    /// footprint is at most 5 x 5 (margin ≤ 2) and inside the film, each footprint pixel's sums
    /// are loaded once and every sample added to them in order, so the
    /// additions, and the bits, are those of one splat after another.
    pub fn splat_pixel(&mut self, px: i32, py: i32, samples: &[(Vec2, Spectrum)], filter: &Filter) {
        match filter.margin() {
            0 => self.splat_pixel_taps::<1>(px, py, samples, filter),
            1 => self.splat_pixel_taps::<3>(px, py, samples, filter),
            2 => self.splat_pixel_taps::<5>(px, py, samples, filter),
            _ => {
                for &(u, l) in samples {
                    self.splat(px, py, u, l, None, filter);
                }
            }
        }
    }

    /// [`Self::splat_pixel`] for a footprint of `N` x `N` pixels (N ≤ 5).
    #[inline(always)]
    fn splat_pixel_taps<const N: usize>(&mut self, px: i32, py: i32, samples: &[(Vec2, Spectrum)], filter: &Filter) {
        let m = (N / 2) as i32;
        let inside = self.moments.is_empty()
            && px >= m
            && py >= m
            && px + m < self.width as i32
            && py + m < self.height as i32
            && samples.iter().all(|(u, l)| l.is_finite() && (0.0..=1.0).contains(&u.x) && (0.0..=1.0).contains(&u.y));
        if !inside {
            for &(u, l) in samples {
                self.splat(px, py, u, l, None, filter);
            }
            return;
        }
        const GROUP: usize = 16;
        let width = self.width as usize;
        let first = (py - m) as usize * width + (px - m) as usize;
        for group in samples.chunks(GROUP) {
            // Per sample its radiance and weight, and its taps' weights
            // along x and along y.
            let mut lw = [glam::Vec4::ZERO; GROUP];
            let mut wx = [[0.0f32; N]; GROUP];
            let mut wy = [[0.0f32; N]; GROUP];
            for (i, &(u, l)) in group.iter().enumerate() {
                lw[i] = l.extend(1.0);
                (wx[i], wy[i]) = (filter.taps::<N>(u.x), filter.taps::<N>(u.y));
            }
            let n = group.len();
            // A footprint row's 4 N sums stay in registers while every
            // sample is added to them, in sample order; LLVM vectorises the
            // channels and taps (the same products and sums, operation for
            // operation, as `add_widened`).
            for ky in 0..N {
                let row = &mut self.acc[first + ky * width..][..N];
                let mut sums: [[f64; 4]; N] = row.try_into().unwrap();
                for ((lw, wx), wy) in lw[..n].iter().zip(&wx[..n]).zip(&wy[..n]) {
                    let w: [f32; N] = std::array::from_fn(|k| wx[k] * wy[ky]);
                    let c = lw.to_array();
                    for (sum, w) in sums.iter_mut().zip(w) {
                        for (s, c) in sum.iter_mut().zip(c) {
                            *s += (c * w) as f64;
                        }
                    }
                }
                row.copy_from_slice(&sums);
            }
        }
    }

    /// [`Self::splat`] with weight arrays of `N` ≥ 2 · margin + 1 taps.
    #[inline(always)]
    fn splat_taps<const N: usize>(
        &mut self,
        px: i32,
        py: i32,
        u: Vec2,
        l: Spectrum,
        aov: Option<&[f32]>,
        filter: &Filter,
    ) {
        let m = filter.margin().min(MAX_MARGIN) as i32;
        let taps = (2 * m + 1) as usize;
        let (mut wx, mut wy) = ([0.0f32; N], [0.0f32; N]);
        for k in 0..taps {
            // Distance from the sample to the centre of pixel p - m + k.
            let d = (m - k as i32) as f32;
            wx[k] = filter.weight(u.x + d - 0.5);
            wy[k] = filter.weight(u.y + d - 0.5);
        }
        // Only the taps inside the film with a non-zero weight: a Gaussian
        // of radius 2 reaches 4 of its 5 taps per axis, so this skips 9 of
        // 25 pixels without a test per pixel.
        let xs = nonzero_taps(&wx[..taps], px - m, self.width);
        let ys = nonzero_taps(&wy[..taps], py - m, self.height);
        if aov.is_none() && self.moments.is_empty() {
            // The common case, without tests per pixel: beauty and weight only.
            let (x0, n) = ((px - m + xs.start as i32) as usize, xs.len());
            let lw = l.extend(1.0);
            let wx = &wx[xs];
            for ky in ys {
                let row = (py - m + ky as i32) as usize * self.width as usize + x0;
                let wy = wy[ky];
                for (a, &wx) in self.acc[row..row + n].iter_mut().zip(wx) {
                    add_widened(a, lw * (wx * wy));
                }
            }
            return;
        }
        for ky in ys {
            let y = (py - m + ky as i32) as u32;
            for kx in xs.clone() {
                let x = (px - m + kx as i32) as u32;
                let w = wx[kx] * wy[ky];
                if w == 0.0 {
                    continue;
                }
                self.add(x, y, l, w);
                if let Some(a) = aov {
                    self.add_aov(x, y, a, w);
                }
            }
        }
    }

    /// Splats `l` as Mitsuba's normalised `ImageBlock` does (the particle
    /// tracer's splats): the filter's weights around pixel (`px`, `py`) +
    /// `u` scaled to sum to 1 over the whole footprint, added to Σ w·L only
    /// (the weight sum counts samples per pixel instead). Pixels outside
    /// the film are dropped; `px`, `py` may lie outside it.
    pub fn splat_normalized(&mut self, px: i32, py: i32, u: Vec2, l: Spectrum, filter: &Filter) {
        self.splat_to_sums(px, py, u, l, filter, true);
    }

    /// Splats `l` as a camera sample at pixel (`px`, `py`) + `u` would be
    /// ([`Self::splat`]), but into Σ w·L only: radiance that a camera
    /// sample's weight already counts (the caustics' light paths,
    /// `integrator::path::caustics`). Pixels outside the film are dropped;
    /// `px`, `py` may lie outside it.
    pub fn splat_radiance(&mut self, px: i32, py: i32, u: Vec2, l: Spectrum, filter: &Filter) {
        self.splat_to_sums(px, py, u, l, filter, false);
    }

    /// [`Self::splat_normalized`] (`normalized`) or [`Self::splat_radiance`].
    fn splat_to_sums(&mut self, px: i32, py: i32, u: Vec2, l: Spectrum, filter: &Filter, normalized: bool) {
        let m = filter.margin().min(MAX_MARGIN) as i32;
        let taps = (2 * m + 1) as usize;
        let (mut wx, mut wy) = ([0.0f32; 2 * MAX_MARGIN as usize + 1], [0.0f32; 2 * MAX_MARGIN as usize + 1]);
        for k in 0..taps {
            let d = (m - k as i32) as f32;
            wx[k] = filter.weight(u.x + d - 0.5);
            wy[k] = filter.weight(u.y + d - 0.5);
        }
        let norm = if normalized { wx[..taps].iter().sum::<f32>() * wy[..taps].iter().sum::<f32>() } else { 1.0 };
        if norm == 0.0 || !norm.is_finite() {
            return;
        }
        let xs = nonzero_taps(&wx[..taps], px - m, self.width);
        let ys = nonzero_taps(&wy[..taps], py - m, self.height);
        for ky in ys {
            let y = (py - m + ky as i32) as u32;
            for kx in xs.clone() {
                let x = (px - m + kx as i32) as u32;
                let w = wx[kx] * wy[ky] / norm;
                let i = (y * self.width + x) as usize;
                let a = &mut self.acc[i];
                // Light paths' splats into camera samples' sums also keep
                // their own moments, for the variance (see `pixel_variance`).
                let mut moments = if normalized { None } else { self.moments.get_mut(i) };
                for (c, v) in l.to_array().into_iter().enumerate() {
                    let s = (v * w) as f64;
                    a[c] += s;
                    if let Some(m) = moments.as_deref_mut() {
                        m[SPLAT_SUM + c] += s;
                        m[SPLAT_SQUARES + c] += s * s;
                    }
                }
            }
        }
    }

    /// Adds another film's sums (e.g. from another machine or pass).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        assert_eq!(self.layers(), other.layers());
        for i in 0..self.acc.len() {
            self.add_pixel(i, other, i);
        }
    }

    /// The image: linear RGB, row-major, top row first.
    pub fn develop(&self) -> Vec<[f32; 3]> {
        self.acc
            .iter()
            .map(|&[r, g, b, w]| if w > 0.0 { [(r / w) as f32, (g / w) as f32, (b / w) as f32] } else { [0.0; 3] })
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
        let mut out = Vec::with_capacity(self.acc.len() * m);
        for (i, &[.., w]) in self.acc.iter().enumerate() {
            for c in 0..m {
                out.push(if w > 0.0 { (self.aov[i * n + off + c] / w) as f32 } else { 0.0 });
            }
        }
        Some(out)
    }

    /// The weighted means of the integrator's output channel `c` (an index
    /// into [`Film::channels`]), one value per pixel.
    pub fn develop_channel(&self, c: usize) -> Vec<f32> {
        let n = self.aov_channels();
        let off = channel_count(&self.aov_kinds) + c;
        self.acc
            .iter()
            .enumerate()
            .map(|(i, &[.., w])| if w > 0.0 { (self.aov[i * n + off] / w) as f32 } else { 0.0 })
            .collect()
    }

    /// Variance of pixel `i`'s mean, per channel (None without moments).
    ///
    /// The pixel value is the ratio estimator R = Σ wL / Σ w; its variance by
    /// the delta method (the standard error of a weighted mean) is
    /// Σ w² (L − R)² / (Σ w)², expanded into the stored moments. Given the
    /// weights, with W = Σ w, S_k = Σ w^k and samples L of variance σ², its
    /// expectation is σ² (b − 2ab + b²) while the true variance is σ² b,
    /// where a = S3 / (W S2) and b = S2 / W² (1 / b is Kish's effective
    /// sample count n); so it is divided by 1 − 2a + b, which for equal
    /// weights is the familiar n/(n − 1) and under a Gaussian filter is
    /// about 3 % larger. Fewer than 1.5 effective samples: infinite.
    ///
    /// Light paths' splats ([`Self::splat_radiance`]) add Y = Σ_j s_j / W
    /// to the pixel, a sum over independent light paths j, most of which
    /// add nothing here: Var(Y) = Σ_j Var(s_j) / W², estimated by
    /// Σ_j s_j² / W² (it leaves in Σ_j (E s_j)² / W², which is small
    /// beside it when each light path rarely reaches the pixel). The camera
    /// samples' part is taken about their own mean, the pixel's less Y.
    #[inline]
    pub fn pixel_variance(&self, i: usize) -> Option<[f64; 3]> {
        let m = self.moments.get(i)?;
        let w = self.acc[i][3];
        let n_eff = if m[0] > 0.0 { w * w / m[0] } else { 0.0 };
        let (a, b) = (m[7] / (w * m[0]), m[0] / (w * w));
        let unbias = 1.0 - 2.0 * a + b;
        if n_eff < 1.5 || unbias.is_nan() || unbias <= 1e-9 {
            return Some([f64::INFINITY; 3]);
        }
        let mut v = [0.0; 3];
        for c in 0..3 {
            let r = (self.acc[i][c] - m[SPLAT_SUM + c]) / w;
            let s = m[4 + c] - 2.0 * r * m[1 + c] + r * r * m[0];
            v[c] = (s.max(0.0) / unbias + m[SPLAT_SQUARES + c]) / (w * w);
        }
        Some(v)
    }

    /// The variance of each pixel's mean (R, G, B), or None without moments.
    pub fn develop_variance(&self) -> Option<Vec<[f32; 3]>> {
        if !self.has_variance() {
            return None;
        }
        Some(
            (0..self.acc.len())
                .map(|i| self.pixel_variance(i).unwrap().map(|v| if v.is_finite() { v as f32 } else { f32::MAX }))
                .collect(),
        )
    }

    /// Estimated relative error of pixel `i`: the mean over R, G, B of
    /// Var(mean) / (mean² + ε), the expected relMSE of the pixel against the
    /// converged image (`penumbra diff`'s relMSE, with the variance of the
    /// mean standing in for the squared error).
    #[inline]
    pub fn pixel_rel_error(&self, i: usize) -> Option<f64> {
        let v = self.pixel_variance(i)?;
        let w = self.acc[i][3];
        let mut e = 0.0;
        for (c, vc) in v.iter().enumerate() {
            let r = if w > 0.0 { self.acc[i][c] / w } else { 0.0 };
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
        let n = self.acc.len().max(1) as f64;
        Some((0..self.acc.len()).map(|i| self.pixel_rel_error(i).unwrap()).sum::<f64>() / n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The widening add (AVX where built with it) gives the scalar form's bits.
    #[test]
    fn widened_add_is_the_scalar_add() {
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            f32::from_bits((state >> 32) as u32 & 0x7f7f_ffff) // finite, either sign's magnitude
        };
        for _ in 0..10_000 {
            let mut a = [next() as f64 * 1e3, next() as f64, -(next() as f64), 0.5];
            let v = glam::Vec4::new(next(), -next(), next() * 1e-20, next());
            let mut want = a;
            for (w, c) in want.iter_mut().zip(v.to_array()) {
                *w += c as f64;
            }
            add_widened(&mut a, v);
            assert_eq!(a.map(f64::to_bits), want.map(f64::to_bits));
        }
    }
    use crate::testing::TestRng;

    /// The splat of a pixel's samples together gives the bits of one splat
    /// after another (the trimming loop): runs of samples (zero, negative
    /// and large radiance too) near and away from the film's edges, for
    /// filters of margins 0, 1 and 2.
    #[test]
    fn pixel_splat_is_one_splat_after_another() {
        let kinds = [
            FilterKind::Gaussian { stddev: 0.5 },
            FilterKind::Gaussian { stddev: 0.376 },
            FilterKind::Gaussian { stddev: 0.624 },
            FilterKind::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 },
            FilterKind::CatmullRom,
            FilterKind::Lanczos { lobes: 2 },
            FilterKind::Box,
            FilterKind::Tent { radius: 1.0 },
            FilterKind::Tent { radius: 1.4 },
            FilterKind::Gaussian { stddev: 0.3 },
        ];
        let bits = |f: &Film| f.acc.iter().flat_map(|a| a.map(f64::to_bits)).collect::<Vec<_>>();
        for kind in kinds {
            let filter = Filter::new(kind);
            let m = filter.margin() as i32;
            assert!(m <= 2, "{kind:?}");
            let (mut one_by_one, mut grouped) = (Film::new(9, 7), Film::new(9, 7));
            let mut rng = TestRng::new(7);
            let (mut i, mut inside) = (0, 0);
            // Runs of 1 to 40 samples, non-finite ones left out as
            // `add_sample` leaves them.
            while i < 4000 {
                let (px, py) = ((rng.next_f32() * 9.0) as i32, (rng.next_f32() * 7.0) as i32);
                let run = 1 + (rng.next_f32() * 40.0) as usize;
                let samples: Vec<(Vec2, Spectrum)> = (0..run)
                    .map(|j| {
                        let u = Vec2::new(rng.next_f32(), rng.next_f32());
                        let l = Spectrum::new(rng.next_f32(), -rng.next_f32(), rng.next_f32() * 1e6);
                        (u, l * ((i + j) % 5) as f32)
                    })
                    .collect();
                for &(u, l) in &samples {
                    one_by_one.splat(px, py, u, l, None, &filter);
                }
                grouped.splat_pixel(px, py, &samples, &filter);
                inside += (px >= m && py >= m && px + m < 9 && py + m < 7) as usize * run;
                i += run;
            }
            assert!(inside > 500, "{kind:?}: {inside}");
            assert_eq!(bits(&grouped), bits(&one_by_one), "{kind:?}");
        }
    }

    /// Equal weights: the layer is s²/n, the unbiased variance of a mean.
    #[test]
    fn equal_weights_give_s2_over_n() {
        let mut f = Film::with_layers(1, 1, &FilmLayers { aovs: vec![], variance: true, ..Default::default() });
        for v in [1.0, 2.0, 3.0, 4.0] {
            f.add(0, 0, Spectrum::splat(v), 0.5);
        }
        let v = f.pixel_variance(0).unwrap();
        assert!((v[0] - (5.0 / 3.0) / 4.0).abs() < 1e-12, "{v:?}");
    }

    /// Unequal weights: averaged over many pixels of random weights and
    /// independent values of variance σ², the layer's mean is the true
    /// variance of the weighted mean, σ² Σ w² / (Σ w)², averaged likewise
    /// (4 standard errors of that mean); the n/(n − 1) correction alone,
    /// right for equal weights, must be off by more than that.
    #[test]
    fn unequal_weights_are_unbiased() {
        let mut rng = TestRng::new(7);
        let (pixels, n) = (40_000, 6);
        let (mut est, mut truth, mut sq, mut kish) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..pixels {
            let mut f = Film::with_layers(1, 1, &FilmLayers { aovs: vec![], variance: true, ..Default::default() });
            let (mut w1, mut w2, mut w3) = (0.0f64, 0.0f64, 0.0f64);
            for _ in 0..n {
                // Weights spread as a filter's are; values uniform, σ² = 1/12.
                let w = 0.25 + 1.5 * rng.next_f32();
                f.add(0, 0, Spectrum::splat(rng.next_f32()), w);
                w1 += w as f64;
                w2 += (w as f64).powi(2);
                w3 += (w as f64).powi(3);
            }
            let (a, b) = (w3 / (w1 * w2), w2 / (w1 * w1));
            let v = f.pixel_variance(0).unwrap()[0];
            est += v;
            sq += v * v;
            kish += v * (1.0 - 2.0 * a + b) / (1.0 - b);
            truth += w2 / (w1 * w1) / 12.0;
        }
        let (m, t) = (est / pixels as f64, truth / pixels as f64);
        let se = ((sq / pixels as f64 - m * m) / pixels as f64).sqrt();
        assert!((m - t).abs() < 4.0 * se, "layer mean {m}, true {t}, se {se}");
        let k = kish / pixels as f64;
        assert!((k - t).abs() > 8.0 * se, "n/(n - 1) alone ({k}) would pass against {t} ± {se}");
        assert!(se < 0.01 * t, "se {se} too large to see a 4 % bias in {t}");
    }

    /// The tabulated Gaussian is within 2e-6 of the profile everywhere.
    #[test]
    fn tabulated_profile_matches() {
        for stddev in [0.5f32, 0.3, 1.7] {
            let f = Filter::new(FilterKind::Gaussian { stddev });
            for i in 0..=100_000 {
                let x = -1.1 * f.radius + 2.2 * f.radius * i as f32 / 100_000.0;
                assert!((f.weight(x) - f.eval(x)).abs() < 2e-6, "σ {stddev} x {x}: {} vs {}", f.weight(x), f.eval(x));
            }
        }
    }

    /// Mitchell–Netravali, Catmull–Rom and Lanczos profiles against values
    /// printed by Mitsuba 3.9.1 (`mi.load_dict({'type': 'mitchell'}).eval(x)`).
    #[test]
    fn negative_lobed_profiles_match_mitsuba() {
        let xs = [0.0, 0.3, 0.9, 1.2, 1.7, 2.5];
        let cases: [(FilterKind, [f32; 6]); 5] = [
            (
                FilterKind::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 },
                [0.888889, 0.740389, 0.1193889, -0.0142223, -0.0194999, 0.0],
            ),
            (FilterKind::Mitchell { b: 0.2, c: 0.4 }, [0.9333333, 0.7704333, 0.0990332, -0.0341336, -0.0243004, 0.0]),
            (FilterKind::CatmullRom, [1.0, 0.8155, 0.0685, -0.0640001, -0.0314999, 0.0]),
            (FilterKind::Lanczos { lobes: 3 }, [1.0, 0.8443431, 0.0938159, -0.1180006, -0.0832311, 0.0243171]),
            (FilterKind::Lanczos { lobes: 2 }, [1.0, 0.8269746, 0.0763568, -0.078667, -0.0257535, 0.0]),
        ];
        for (kind, want) in cases {
            let f = Filter::new(kind);
            for (x, w) in xs.iter().zip(want) {
                assert!((f.weight(*x) - w).abs() < 2e-6, "{kind:?} at {x}: {} vs {w}", f.weight(*x));
                assert_eq!(f.weight(-*x), f.weight(*x));
            }
        }
        assert_eq!(Filter::new(FilterKind::Lanczos { lobes: 3 }).margin(), 3);
        assert_eq!(Filter::new(FilterKind::Mitchell { b: 0.0, c: 0.5 }).margin(), 2);
    }

    /// Splatting uniformly placed samples of a function g converges to the
    /// filtered image: at each pixel ∫ f(p - c) g(p) dp / ∫ f(p - c) dp
    /// (over the film), checked against midpoint quadrature.
    #[test]
    fn splatting_converges_to_the_filtered_image() {
        let g = |p: Vec2| 1.0 + (0.7 * p.x).sin() * (0.4 * p.y).cos() + 0.05 * p.x;
        let kinds = [
            FilterKind::Box,
            FilterKind::Tent { radius: 1.0 },
            FilterKind::Gaussian { stddev: 0.5 },
            FilterKind::Gaussian { stddev: 0.376 },
            FilterKind::Gaussian { stddev: 0.624 },
            FilterKind::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 },
            FilterKind::CatmullRom,
            FilterKind::Lanczos { lobes: 3 },
        ];
        for kind in kinds {
            let filter = Filter::new(kind);
            let (w, h) = (8u32, 6u32);
            let mut film = Film::new(w, h);
            let n = 64; // n x n stratified samples per pixel
            for py in 0..h {
                for px in 0..w {
                    for i in 0..n * n {
                        let u = Vec2::new(((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32);
                        let p = Vec2::new(px as f32, py as f32) + u;
                        film.splat(px as i32, py as i32, u, Spectrum::splat(g(p)), None, &filter);
                    }
                }
            }
            let img = film.develop();
            let q = 400; // quadrature points per pixel and axis
            for (cy, cx) in [(0u32, 0u32), (2, 3), (5, 7), (3, 0)] {
                let c = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5);
                let (mut num, mut den) = (0.0f64, 0.0f64);
                for j in 0..h * q {
                    for i in 0..w * q {
                        let p = Vec2::new((i as f32 + 0.5) / q as f32, (j as f32 + 0.5) / q as f32);
                        let f = (filter.eval(p.x - c.x) * filter.eval(p.y - c.y)) as f64;
                        num += f * g(p) as f64;
                        den += f;
                    }
                }
                let expect = (num / den) as f32;
                let got = img[(cy * w + cx) as usize][0];
                assert!((got - expect).abs() < 2e-3 * expect, "{kind:?} pixel ({cx},{cy}): {got} vs {expect}");
            }
        }
    }
}
