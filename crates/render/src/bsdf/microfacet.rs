//! Microfacet distributions (Beckmann, GGX), anisotropic, with sampling of
//! the distribution of visible normals, following Mitsuba 3's
//! `MicrofacetDistribution` (always `sample_visible = true`).
//!
//! Conventions (as Mitsuba): D(m) is normalised over projected area,
//! ∫ D(m) cos θ_m dω_m = 1; the Smith masking term G1(v, m) is zero when
//! v sees the back of the microfacet (dot(v, m) · cos θ_v <= 0); the visible
//! normal density is D_v(m) = G1(v, m) |dot(v, m)| D(m) / cos θ_v.
//!
//! Deliberate difference from Mitsuba: its Beckmann G1 is a rational fit
//! of Λ (relative error up to ~0.35 %, see `beckmann_g1_fit` and the test
//! `beckmann_fit_vs_exact`), while its sampler draws from the *exact* visible
//! normal distribution. We use the exact Λ(a) = (erf(a) − 1)/2 +
//! exp(−a²)/(2a√π) so that the density and the sampler agree.

use crate::geometry::SurfaceInteraction;
use crate::math::{safe_sqrt, PI};
use crate::simd::{Float, Mask as _, V3};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Which normal distribution function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MicrofacetType {
    /// The Beckmann distribution (Mitsuba `beckmann`).
    Beckmann,
    /// The GGX (Trowbridge–Reitz) distribution (Mitsuba `ggx`).
    Ggx,
}

/// A microfacet distribution in the local shading frame (normal = +z);
/// `alpha_u` is the roughness along the frame's `s` axis, `alpha_v` along `t`.
#[derive(Debug, Clone, Copy)]
pub struct Microfacet {
    /// Normal distribution function.
    pub kind: MicrofacetType,
    /// Roughness α along the shading frame's `s` axis.
    pub alpha_u: f32,
    /// Roughness α along the shading frame's `t` axis.
    pub alpha_v: f32,
}

/// A distribution with (possibly textured) roughness along `s` and `t`, as
/// `roughconductor` and `roughdielectric` store it.
#[derive(Debug, Clone)]
pub struct Roughness {
    /// Normal distribution function.
    pub kind: MicrofacetType,
    /// Roughness α along `s`.
    pub alpha_u: Texture,
    /// Roughness α along `t`.
    pub alpha_v: Texture,
}

impl Roughness {
    /// The distribution at a hit (`Microfacet` keeps the roughness positive).
    #[inline]
    pub fn at(&self, si: &SurfaceInteraction) -> Microfacet {
        Microfacet { kind: self.kind, alpha_u: self.alpha_u.eval_1(si), alpha_v: self.alpha_v.eval_1(si) }
    }

    /// Constant and different roughness along `s` and `t` (textured
    /// roughness counts among the plugin's textures).
    pub fn anisotropic(&self) -> bool {
        matches!((self.alpha_u.constant(), self.alpha_v.constant()), (Some(u), Some(v)) if u != v)
    }
}

const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// Complementary error function in f64, relative error < 1.2e-7 everywhere
/// (the Chebyshev-fitted form of Numerical Recipes, `erfcc`).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Error function (absolute error < 1.2e-7).
#[inline]
pub fn erf(x: f64) -> f64 {
    1.0 - erfc(x)
}

/// Inverse error function on (−1, 1): Giles' single-precision approximation
/// ("Approximating the erfinv function", 2010), evaluated in f64. Its
/// residual |erf(x) − y| stays below 9e-8, within [`erf`]'s own error, so
/// Newton steps against `erf` (which cost four `exp` and tripled the price
/// of Beckmann sampling) gain nothing.
pub fn erfinv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let w = -((1.0 - y) * (1.0 + y)).ln();
    if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.810_226_36e-08;
        for c in [
            3.432_739_39e-07,
            -3.523_387_7e-06,
            -4.391_506_54e-06,
            0.000_218_580_87,
            -0.001_253_725_03,
            -0.004_177_681_64,
            0.246_640_727,
            1.501_409_41,
        ] {
            p = c + p * w;
        }
        p * y
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_257;
        for c in [
            0.000_100_950_558,
            0.001_349_343_22,
            -0.003_673_428_44,
            0.005_739_507_73,
            -0.007_622_461_3,
            0.009_438_870_47,
            1.001_674_06,
            2.832_976_82,
        ] {
            p = c + p * w;
        }
        p * y
    }
}

/// Smith's Λ for the Beckmann distribution, exact, at a = 1 / (α tan θ).
pub fn beckmann_lambda(a: f64) -> f64 {
    if a <= 0.0 {
        return f64::INFINITY;
    }
    // (erf(a) − 1)/2 + exp(−a²)/(2a√π), written with erfc to avoid cancellation.
    0.5 * ((-a * a).exp() * INV_SQRT_PI / a - erfc(a))
}

/// [`beckmann_lambda`] in f32, as every shading call evaluates it: with
/// erfc(a) = t e^{−a²} e^{P(t)} (the erfcc form of [`erfc`]),
/// Λ = ½ e^{−a²} (1/(a√π) − t e^{P(t)}), both exponentials by the lanes'
/// polynomial `exp` (libm's f64 `exp` took half of a rough-metal render).
/// G1 = 1/(1 + Λ) stays within 1e-6 of the f64 form for 0 < a < 4 (test
/// `beckmann_g1_in_f32_is_the_f64_one`).
#[inline]
pub fn beckmann_lambda_f32(a: f32) -> f32 {
    beckmann_lambda_lanes(a)
}

/// [`beckmann_lambda_f32`] for any lanes (the same operations per lane).
#[inline(always)]
pub(crate) fn beckmann_lambda_lanes<F: Float>(a: F) -> F {
    let c = F::splat;
    let t = c(1.0) / (c(1.0) + c(0.5) * a);
    let p = c(-1.265_512_2)
        + t * (c(1.000_023_7)
            + t * (c(0.374_091_96)
                + t * (c(0.096_784_18)
                    + t * (c(-0.186_288_06)
                        + t * (c(0.278_868_07)
                            + t * (c(-1.135_204)
                                + t * (c(1.488_515_9) + t * (c(-0.822_152_2) + t * c(0.170_872_77)))))))));
    c(0.5) * crate::simd::exp(-a * a) * (c(INV_SQRT_PI as f32) / a - t * crate::simd::exp(p))
}

/// The a = 1/(α tan θ) from which the Beckmann G1 is 1.0 in f32.
pub(crate) const BECKMANN_G1_ONE: f64 = 4.0;

/// [`Microfacet::smith_g1`] in lanes, for the roughnesses `au`, `av` as
/// `Microfacet::alphas` floors them: its early returns become selects, so
/// every lane is bitwise the scalar value.
#[inline(always)]
pub(crate) fn smith_g1_lanes<F: Float>(au: F, av: F, beckmann: bool, v: V3<F>, m: V3<F>) -> F {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let (ax, ay) = (au * v.x, av * v.y);
    let xy = ax * ax + ay * ay;
    let t = xy / (v.z * v.z);
    let g = if beckmann {
        let a = one / t.sqrt();
        F::select(a.cmp_ge(F::splat(BECKMANN_G1_ONE as f32)), one, one / (one + beckmann_lambda_lanes(a)))
    } else {
        F::splat(2.0) / (one + (one + t).sqrt())
    };
    let g = F::select(xy.cmp_eq(zero), one, g);
    F::select((v.dot(m) * v.z).cmp_le(zero), zero, g)
}

/// Mitsuba's rational fit of the Beckmann G1 (kept for comparison only).
pub fn beckmann_g1_fit(a: f32) -> f32 {
    if a >= 1.6 {
        1.0
    } else {
        (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
    }
}

impl Microfacet {
    /// A distribution with the same roughness `alpha` along both axes.
    pub fn isotropic(kind: MicrofacetType, alpha: f32) -> Microfacet {
        Microfacet { kind, alpha_u: alpha, alpha_v: alpha }
    }

    /// Roughness values clamped to Mitsuba's minimum of 1e-4.
    #[inline]
    pub(crate) fn alphas(&self) -> (f32, f32) {
        (self.alpha_u.max(1e-4), self.alpha_v.max(1e-4))
    }

    /// D(m), normalised over projected area.
    pub fn eval(&self, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let cos2 = m.z * m.z;
        let r = match self.kind {
            MicrofacetType::Beckmann => {
                crate::simd::exp(-((m.x / au).powi(2) + (m.y / av).powi(2)) / cos2) / (PI * au * av * cos2 * cos2)
            }
            MicrofacetType::Ggx => 1.0 / (PI * au * av * ((m.x / au).powi(2) + (m.y / av).powi(2) + cos2).powi(2)),
        };
        if r * m.z > 1e-20 {
            r
        } else {
            0.0
        }
    }

    /// Smith's masking function G1(v, m).
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = self.alphas();
        let xy_alpha_2 = (au * v.x).powi(2) + (av * v.y).powi(2);
        if xy_alpha_2 == 0.0 {
            return 1.0;
        }
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        match self.kind {
            MicrofacetType::Beckmann => {
                let a = 1.0 / tan_theta_alpha_2.sqrt();
                // From a = 4 on, Λ(a) < 3e-10 and 1/(1 + Λ) rounds to 1 in
                // f32 (test `beckmann_g1_is_exactly_one_from_a_4`).
                if a >= BECKMANN_G1_ONE as f32 {
                    return 1.0;
                }
                1.0 / (1.0 + beckmann_lambda_f32(a))
            }
            MicrofacetType::Ggx => 2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt()),
        }
    }

    /// Separable shadowing-masking G1(wi, m) · G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density of [`Microfacet::sample`]: the visible normal distribution
    /// D_wi(m) = G1(wi, m) |dot(wi, m)| D(m) / cos θ_wi (wi.z > 0).
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        let d = self.eval(m);
        if d == 0.0 {
            return 0.0;
        }
        d * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z
    }

    /// Samples a visible normal for `wi` (upper hemisphere) and returns it
    /// with its density (Heitz & d'Eon 2014: stretch, sample the slopes of
    /// the α = 1 configuration, rotate and unstretch).
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        let st = self.stretch(wi);
        let m = self.normal_from_slope(&st, self.sample_visible_11(st.cos_theta, u));
        (m, self.pdf(wi, m))
    }

    /// Step 1 of visible-normal sampling: `wi` in the α = 1 configuration.
    pub(crate) fn stretch(&self, wi: Vec3) -> Stretched {
        let (au, av) = self.alphas();
        let wi_p = Vec3::new(au * wi.x, av * wi.y, wi.z).normalize();
        let sin_theta = safe_sqrt(1.0 - wi_p.z * wi_p.z);
        let (sin_phi, cos_phi) = if sin_theta == 0.0 {
            (0.0, 1.0)
        } else {
            ((wi_p.y / sin_theta).clamp(-1.0, 1.0), (wi_p.x / sin_theta).clamp(-1.0, 1.0))
        };
        Stretched { au, av, sin_phi, cos_phi, cos_theta: wi_p.z }
    }

    /// Step 3: rotate and unstretch a sampled α = 1 slope into a normal.
    #[inline]
    pub(crate) fn normal_from_slope(&self, st: &Stretched, slope: Vec2) -> Vec3 {
        let sx = (st.cos_phi * slope.x - st.sin_phi * slope.y) * st.au;
        let sy = (st.sin_phi * slope.x + st.cos_phi * slope.y) * st.av;
        Vec3::new(-sx, -sy, 1.0).normalize()
    }

    /// Samples the slopes of visible normals for α = 1 and incidence cos θ_i
    /// (in the plane φ = 0).
    fn sample_visible_11(&self, cos_theta_i: f32, u: Vec2) -> Vec2 {
        match self.kind {
            MicrofacetType::Beckmann => Vec2::new(beckmann_slope_x(cos_theta_i, u.x), beckmann_slope_y(u.y)),
            MicrofacetType::Ggx => {
                // Heitz 2018: sample the projected hemisphere of the
                // stretched configuration.
                let p = crate::sampling::warp::sample_concentric_disk(u);
                let s = 0.5 * (1.0 + cos_theta_i);
                let h = safe_sqrt(1.0 - p.x * p.x);
                let py = h + (p.y - h) * s;
                let (x, y) = (p.x, py);
                let z = safe_sqrt(1.0 - x * x - y * y);
                let sin_theta_i = safe_sqrt(1.0 - cos_theta_i * cos_theta_i);
                let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
                Vec2::new((cos_theta_i * y - sin_theta_i * z) * norm, x * norm)
            }
        }
    }
}

/// The stretched incident direction of visible-normal sampling.
pub(crate) struct Stretched {
    au: f32,
    av: f32,
    sin_phi: f32,
    cos_phi: f32,
    pub cos_theta: f32,
}

/// Beckmann visible slopes for α = 1, x component (in the incidence plane):
/// numerical inversion of its CDF in the erf domain (Jakob's improved
/// routine, as Mitsuba's `sample_visible_11`), in f32 with the lanes' `erf`,
/// `erfinv`, `exp` and `ln`: Newton steps on the normalised CDF, kept inside
/// a bisection bracket, until it is within 1e-6 of `ux` (at most
/// [`BECKMANN_NEWTON_STEPS`]). The x and y slopes are independent.
pub(crate) fn beckmann_slope_x(cos_theta_i: f32, ux: f32) -> f32 {
    beckmann_slope_x_lanes(cos_theta_i, ux)
}

/// [`beckmann_slope_x`] for any lanes: each lane steps until its own
/// stopping test holds, as the scalar loop does.
#[inline(always)]
pub(crate) fn beckmann_slope_x_lanes<F: Float>(cos_theta_i: F, ux: F) -> F {
    use crate::simd::{erf, erfinv, exp, ln};
    let c = F::splat;
    let ci = cos_theta_i;
    let tan_i = (c(1.0) - ci * ci).max(c(0.0)).sqrt() / ci;
    let cot_i = c(1.0) / tan_i;
    let flat = tan_i.cmp_eq(c(0.0));
    let maxval = F::select(flat, c(1.0), erf(cot_i));
    // As f32::clamp.
    let ux = c(1.0 - 1e-6).min(c(1e-6).max(ux));
    let k = c(INV_SQRT_PI as f32) * tan_i;
    let tail = F::select(flat, c(0.0), k * exp(-cot_i * cot_i));
    let norm = c(1.0) / (c(1.0) + maxval + tail);
    // Start: the CDF at normal incidence, inverted in closed form.
    let mut x = maxval - (maxval + c(1.0)) * erf((-ln(ux)).sqrt());
    let (mut lo, mut hi) = (c(-1.0), maxval);
    // Outside the bracket (or NaN): bisect instead.
    let outside = |x: F, lo: F, hi: F| !(x.cmp_ge(lo) & x.cmp_le(hi));
    let mut active = F::Mask::splat(true);
    for _ in 0..BECKMANN_NEWTON_STEPS {
        if !active.any() {
            break;
        }
        x = F::select(active & outside(x, lo, hi), c(0.5) * (lo + hi), x);
        let slope = erfinv(x);
        let value = norm * (c(1.0) + x + k * exp(-slope * slope)) - ux;
        active = active & !value.abs().cmp_lt(c(1e-6));
        let up = value.cmp_gt(c(0.0));
        hi = F::select(active & up, x, hi);
        lo = F::select(active & !up, x, lo);
        x = F::select(active, x - value / (norm * (c(1.0) - slope * tan_i)), x);
    }
    x = F::select(outside(x, lo, hi), c(0.5) * (lo + hi), x);
    erfinv(x)
}

/// The most Newton steps of [`beckmann_slope_x`] (it converges in 1-3 but
/// at grazing incidence).
const BECKMANN_NEWTON_STEPS: usize = 10;

/// Beckmann visible slopes for α = 1, y component (a standard normal / √2).
pub(crate) fn beckmann_slope_y(uy: f32) -> f32 {
    beckmann_slope_y_lanes(uy)
}

/// [`beckmann_slope_y`] for any lanes.
#[inline(always)]
pub(crate) fn beckmann_slope_y_lanes<F: Float>(uy: F) -> F {
    let c = F::splat;
    crate::simd::erfinv(c(2.0) * c(1.0 - 1e-6).min(c(1e-6).max(uy)) - c(1.0))
}

/// Mirror reflection of `v` about the microfacet normal `m`.
#[inline]
pub fn reflect_m(v: Vec3, m: Vec3) -> Vec3 {
    2.0 * v.dot(m) * m - v
}

/// Refraction of `v` through the microfacet normal `m` given the signed
/// transmitted cosine and η_t/i ratio from `fresnel_dielectric(dot(v, m), η)`.
#[inline]
pub fn refract_m(v: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (v.dot(m) * eta_ti + cos_t) - v * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{alpha, chi2_test};

    /// The shortcut in `smith_g1`: the full formula gives exactly 1.0 in
    /// f32 for every a from 4 on (dense near 4, then to where erfc underflows),
    /// and not at 3 (so the bound is not vacuous).
    #[test]
    fn beckmann_g1_is_exactly_one_from_a_4() {
        let g1 = |a: f64| (1.0 / (1.0 + beckmann_lambda(a))) as f32;
        let mut a = BECKMANN_G1_ONE;
        while a < 30.0 {
            assert_eq!(g1(a), 1.0, "a = {a}");
            a += if a < 6.0 { 1e-5 } else { 1e-3 };
        }
        assert!(g1(3.0) < 1.0);
    }

    #[test]
    fn beckmann_g1_in_f32_is_the_f64_one() {
        let mut worst: f64 = 0.0;
        for i in 1..=40_000 {
            let a = i as f64 * 1e-4;
            let exact = 1.0 / (1.0 + beckmann_lambda(a));
            let fast = 1.0 / (1.0 + beckmann_lambda_f32(a as f32)) as f64;
            worst = worst.max((fast - exact).abs());
        }
        assert!(worst < 1e-6, "largest |G1 f32 − G1 f64| = {worst:e}");
        // Λ itself, where it is large enough to matter (a < 2), to 1e-5 relative.
        for i in 1..=2000 {
            let a = i as f64 * 1e-3;
            let (exact, fast) = (beckmann_lambda(a), beckmann_lambda_f32(a as f32) as f64);
            assert!((fast - exact).abs() <= 1e-5 * exact, "a = {a}: {fast} vs {exact}");
        }
    }

    /// The f32 slope sampling inverts the visible-slope CDF: against the
    /// same CDF inverted by bisection in f64, at incidences from normal to
    /// 89.9°, the slopes agree to 2e-4 (1 + |slope|).
    #[test]
    fn beckmann_slopes_invert_the_cdf() {
        let mut worst: f64 = 0.0;
        for ci in [1.0f32, 0.9, 0.5, 0.2, 0.05, 0.01, 0.0017] {
            let c = ci as f64;
            let tan_i = (1.0 - c * c).max(0.0).sqrt() / c;
            let (maxval, k) = (if tan_i == 0.0 { 1.0 } else { erf(1.0 / tan_i) }, INV_SQRT_PI * tan_i);
            let cdf = |x: f64| {
                let s = erfinv(x);
                (1.0 + x + k * (-s * s).exp()) / (1.0 + maxval + k * (-1.0 / (tan_i * tan_i)).exp())
            };
            for i in 0..400 {
                let u = (i as f64 + 0.5) / 400.0;
                let (mut lo, mut hi) = (-1.0, maxval);
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if cdf(mid) < u {
                        lo = mid
                    } else {
                        hi = mid
                    }
                }
                let want = erfinv(0.5 * (lo + hi));
                let got = beckmann_slope_x(ci, u as f32) as f64;
                let e = (got - want).abs() / (1.0 + want.abs());
                assert!(e < 2e-4, "cos θ = {ci}, u = {u}: {got} vs {want}");
                worst = worst.max(e);
            }
        }
        let y = beckmann_slope_y(0.8) as f64;
        assert!((y - erfinv(0.6)).abs() < 1e-6, "{y}");
        println!("largest relative slope error {worst:e}");
    }

    fn kinds() -> [MicrofacetType; 2] {
        [MicrofacetType::Beckmann, MicrofacetType::Ggx]
    }

    /// ∫ f dω over the upper hemisphere, uniform in (θ, φ) with many θ rows
    /// so that narrow lobes are resolved.
    fn integrate_hemisphere(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (3000, 256);
        let (dt, dp) = (0.5 * std::f64::consts::PI / nt as f64, 2.0 * std::f64::consts::PI / np as f64);
        let mut acc = 0.0;
        for i in 0..nt {
            let t = (i as f64 + 0.5) * dt;
            let (st, ct) = t.sin_cos();
            for j in 0..np {
                let p = (j as f64 + 0.5) * dp;
                acc += f(Vec3::new((st * p.cos()) as f32, (st * p.sin()) as f32, ct as f32)) * st;
            }
        }
        acc * dt * dp
    }

    #[test]
    fn erf_and_erfinv_accuracy() {
        // Reference values of erf.
        for (x, e) in [
            (0.1, 0.112_462_916_018_284_9),
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
        ] {
            assert!((erf(x) - e).abs() < 2e-7, "erf({x}) = {} vs {e}", erf(x));
            assert!((erf(-x) + e).abs() < 2e-7);
        }
        for i in 1..2000 {
            let y = -1.0 + i as f64 / 1000.0;
            let x = erfinv(y);
            assert!((erf(x) - y).abs() < 1e-7, "erfinv({y}) = {x}");
        }
    }

    /// Mitsuba's rational Beckmann G1 fit against the exact Smith term; the
    /// maximum relative difference is printed (0.0033 measured) and bounded.
    #[test]
    fn beckmann_fit_vs_exact() {
        let mut worst: (f64, f32) = (0.0, 0.0);
        for i in 1..=40_000 {
            let a = i as f32 * 1e-4;
            let exact = 1.0 / (1.0 + beckmann_lambda(a as f64));
            let rel = ((beckmann_g1_fit(a) as f64 - exact) / exact).abs();
            if rel > worst.0 {
                worst = (rel, a);
            }
        }
        println!("max relative difference of Mitsuba's Beckmann G1 fit: {} at a = {}", worst.0, worst.1);
        assert!(worst.0 < 0.005, "{worst:?}");
    }

    #[test]
    fn d_is_normalised_over_projected_area() {
        for kind in kinds() {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                let d = Microfacet { kind, alpha_u: au, alpha_v: av };
                let total = integrate_hemisphere(|m| d.eval(m) as f64 * m.z as f64);
                // GGX's long tail: the last θ rows carry O(α²) density; the
                // grid's error stays far below 1e-3.
                assert!((total - 1.0).abs() < 2e-3, "{kind:?} {au}/{av}: ∫ D cos = {total}");
            }
        }
    }

    #[test]
    fn visible_normal_pdf_integrates_to_one() {
        for kind in kinds() {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                let d = Microfacet { kind, alpha_u: au, alpha_v: av };
                for wi in [Vec3::Z, Vec3::new(0.6, 0.3, 0.5).normalize(), Vec3::new(0.7, -0.7, 0.05).normalize()] {
                    let total = integrate_hemisphere(|m| d.pdf(wi, m) as f64);
                    assert!((total - 1.0).abs() < 3e-3, "{kind:?} {au}/{av} wi={wi}: ∫ D_wi = {total}");
                }
            }
        }
    }

    #[test]
    fn visible_normal_sampling_matches_pdf() {
        let cases: Vec<(MicrofacetType, f32, f32, Vec3)> = kinds()
            .into_iter()
            .flat_map(|k| {
                [
                    (k, 0.3, 0.3, Vec3::Z),
                    (k, 0.8, 0.8, Vec3::new(0.6, 0.3, 0.5).normalize()),
                    (k, 0.5, 0.5, Vec3::new(0.998, 0.0, 0.05).normalize()),
                    (k, 0.1, 0.5, Vec3::new(0.5, 0.5, 0.6).normalize()),
                ]
            })
            .collect();
        let a = alpha(cases.len() + 1);
        for (i, &(kind, au, av, wi)) in cases.iter().enumerate() {
            let d = Microfacet { kind, alpha_u: au, alpha_v: av };
            let p = chi2_test(
                200_000,
                100 + i as u64,
                |_, u| {
                    let (m, pdf) = d.sample(wi, u);
                    assert!((pdf - d.pdf(wi, m)).abs() <= 1e-4 * pdf.max(1.0));
                    Some(m)
                },
                |m| d.pdf(wi, m) as f64,
            );
            println!("VNDF {kind:?} {au}/{av} wi={wi}: p = {p:.4}");
            assert!(p > a, "{kind:?} {au}/{av} wi={wi}: p = {p}");
        }
        // Power: the plain D cos θ density is not the visible-normal density.
        let d = Microfacet::isotropic(MicrofacetType::Ggx, 0.5);
        let wi = Vec3::new(0.9, 0.0, 0.3).normalize();
        let p = chi2_test(200_000, 99, |_, u| Some(d.sample(wi, u).0), |m| (d.eval(m) * m.z) as f64);
        println!("VNDF wrong pdf: p = {p:.3e}");
        assert!(p < a, "wrong pdf accepted: p = {p}");
    }
}

/// Test helpers shared by the microfacet BSDFs' tests.
#[cfg(test)]
pub(crate) mod checks {
    use crate::bsdf::BsdfSample;
    use crate::math::Spectrum;
    use crate::testing::TestRng;
    use glam::{Vec2, Vec3};

    /// A direction with the given cosine, at azimuth φ.
    pub fn dir(cos: f32, phi: f32) -> Vec3 {
        let s = (1.0 - cos * cos).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), cos)
    }

    /// ∫ f dω over the whole sphere, uniform in (θ, φ) with many θ rows so
    /// that narrow lobes are resolved.
    pub fn integrate_sphere_fine(nt: usize, np: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let (dt, dp) = (std::f64::consts::PI / nt as f64, 2.0 * std::f64::consts::PI / np as f64);
        let mut acc = 0.0;
        for i in 0..nt {
            let t = (i as f64 + 0.5) * dt;
            let (st, ct) = t.sin_cos();
            let mut row = 0.0;
            for j in 0..np {
                let p = (j as f64 + 0.5) * dp;
                row += f(Vec3::new((st * p.cos()) as f32, (st * p.sin()) as f32, ct as f32));
            }
            acc += row * st;
        }
        acc * dt * dp
    }

    /// Checks at many random (wo, u) that a sample's weight equals
    /// eval · |cos| / pdf and its pdf equals pdf(); returns the count checked.
    pub fn check_weights(
        seed: u64,
        wos: &[Vec3],
        sample: impl Fn(Vec3, f32, Vec2) -> Option<BsdfSample>,
        eval: impl Fn(Vec3, Vec3) -> Spectrum,
        pdf: impl Fn(Vec3, Vec3) -> f32,
    ) -> usize {
        let mut rng = TestRng::new(seed);
        let (mut n, mut rare) = (0, 0);
        for &wo in wos {
            for _ in 0..2000 {
                let Some(s) = sample(wo, rng.next_f32(), rng.next_2d()) else { continue };
                assert!(!s.delta && s.pdf > 0.0 && s.weight.is_finite(), "{s:?}");
                let p = pdf(wo, s.wi);
                assert!((s.pdf - p).abs() <= 2e-3 * p.max(1e-3), "wo={wo} wi={}: pdf {} vs {p}", s.wi, s.pdf);
                if p < 1e-4 {
                    // Refraction at the edge of total internal reflection: 1 − F
                    // recomputed from wi's half vector may round to 0 while the
                    // sampled weight (where F cancels) does not. Such samples
                    // have probability ~1e-7; count them and require rarity.
                    rare += 1;
                    continue;
                }
                let expect = eval(wo, s.wi) * s.wi.z.abs() / p;
                let tol = 2e-3 * expect.max_element().max(1e-2);
                assert!(
                    (s.weight - expect).abs().max_element() <= tol,
                    "wo={wo:?} wi={:?}: {} vs {expect} (eval {}, pdf {p}, sampled pdf {})",
                    s.wi,
                    s.weight,
                    eval(wo, s.wi),
                    s.pdf
                );
                n += 1;
            }
        }
        assert!(rare * 1000 <= n.max(1000), "{rare} of {n} samples had a vanishing pdf");
        n
    }

    /// Mean sample weight (first channel) and its standard error.
    pub fn albedo(n: usize, seed: u64, wo: Vec3, sample: impl Fn(Vec3, f32, Vec2) -> Option<BsdfSample>) -> (f64, f64) {
        let mut rng = TestRng::new(seed);
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            if let Some(s) = sample(wo, rng.next_f32(), rng.next_2d()) {
                let w = s.weight.x as f64;
                s1 += w;
                s2 += w * w;
            }
        }
        let mean = s1 / n as f64;
        (mean, ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }
}
