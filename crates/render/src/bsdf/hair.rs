//! Mitsuba `hair`: the fibre scattering model of Chiang et al. 2016 (pbrt-v3's
//! hair BSDF), with d'Eon et al.'s longitudinal lobes, a trimmed logistic
//! azimuthal distribution, the R, TT and TRT lobes plus the sum of all longer
//! paths, and scales tilting the lobes.
//!
//! The fibre runs along the shading frame's `t` axis (local +y, Mitsuba's
//! `tangent = (0, 1, 0)`); the longitudinal angle θ is measured from the
//! fibre's normal plane (sin θ = w.y), the azimuth φ = atan2(w.z, w.x) in that
//! plane, and the offset h across the fibre is sin γ of the direction's
//! projection. The model scatters to both sides of the surface (light
//! crosses the fibre), so it is not one-sided.
//!
//! | parameter              | type            | default          |
//! |------------------------|-----------------|------------------|
//! | longitudinal_roughness | float in [0, 1] | 0.3              |
//! | azimuthal_roughness    | float in [0, 1] | 0.3              |
//! | scale_tilt             | float (degrees) | 2                |
//! | int_ior                | float or name   | amber (1.55)     |
//! | ext_ior                | float or name   | air (1.000277)   |
//! | eumelanin              | float           | 1.3              |
//! | pheomelanin            | float           | 0.2              |
//! | sigma_a                | spectrum/texture | (pigments instead) |
//! | scale                  | float           | 1 (multiplies sigma_a) |
//!
//! Absorption per unit of the fibre's radius is σ_a = eumelanin · (0.419,
//! 0.697, 1.37) + pheomelanin · (0.187, 0.4, 1.05) (Mitsuba's RGB variants),
//! or `scale · sigma_a` where given (not together with the pigments).
//!
//! One deliberate difference from Mitsuba 3.9.1: when its sampler picks the
//! lobe of the longer paths (p = 3) it leaves the tilted incident angle at
//! zero, so every such sample lies in the fibre's normal plane, while its
//! pdf (and eval) spread that lobe around the incident angle. Here the lobe
//! is sampled about the incident angle, as the pdf says (pbrt-v3), so that
//! sampling and pdf agree; images differ only through the directions of
//! those samples, whose weight is the same.

use super::fresnel::fresnel_dielectric;
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::{luminance, safe_acos, safe_asin, safe_sqrt, Spectrum, INV_2PI, PI};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// The number of explicit lobes (R, TT, TRT); the next one sums the rest.
const P_MAX: usize = 3;

/// Eumelanin's absorption per unit radius (d'Eon et al. 2011), linear RGB.
pub const EUMELANIN_SIGMA_A: Spectrum = Spectrum::new(0.419, 0.697, 1.37);
/// Pheomelanin's absorption per unit radius, linear RGB.
pub const PHEOMELANIN_SIGMA_A: Spectrum = Spectrum::new(0.187, 0.4, 1.05);

/// The constants of the lobes, computed once per material as Mitsuba's `update()`.
#[derive(Debug, Clone, Copy)]
pub struct HairLobes {
    /// Relative IOR of the fibre.
    pub eta: f32,
    /// Longitudinal variance of each lobe (R, TT, TRT, rest).
    pub v: [f32; P_MAX + 1],
    /// Scale of the azimuthal logistic distribution.
    pub s: f32,
    /// sin(2^k α) for the scale tilt α, k = 0, 1, 2.
    pub sin_2k_alpha: [f32; 3],
    /// cos(2^k α).
    pub cos_2k_alpha: [f32; 3],
}

impl HairLobes {
    /// The lobes' constants for the two roughnesses (in [0, 1]), the scale
    /// tilt in degrees and the relative IOR.
    pub fn new(longitudinal_roughness: f32, azimuthal_roughness: f32, scale_tilt_deg: f32, eta: f32) -> HairLobes {
        let mut sin_2k_alpha = [0.0; 3];
        let mut cos_2k_alpha = [0.0; 3];
        sin_2k_alpha[0] = scale_tilt_deg.to_radians().sin();
        cos_2k_alpha[0] = safe_sqrt(1.0 - sin_2k_alpha[0] * sin_2k_alpha[0]);
        for i in 1..3 {
            sin_2k_alpha[i] = 2.0 * cos_2k_alpha[i - 1] * sin_2k_alpha[i - 1];
            cos_2k_alpha[i] = cos_2k_alpha[i - 1] * cos_2k_alpha[i - 1] - sin_2k_alpha[i - 1] * sin_2k_alpha[i - 1];
        }
        let b = azimuthal_roughness;
        let s = (PI / 8.0).sqrt() * (0.265 * b + 1.194 * b * b + 5.372 * b.powi(22));
        let l = longitudinal_roughness;
        let v0 = (0.726 * l + 0.812 * l * l + 3.7 * l.powi(20)).powi(2);
        HairLobes { eta, v: [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0], s, sin_2k_alpha, cos_2k_alpha }
    }

    /// (sin, |cos|) of the incident longitudinal angle tilted by the scales for lobe `p`.
    #[inline]
    fn reframe(&self, sin_t: f32, cos_t: f32, p: usize) -> (f32, f32) {
        let (s, c) = match p {
            0 => (
                sin_t * self.cos_2k_alpha[1] - cos_t * self.sin_2k_alpha[1],
                cos_t * self.cos_2k_alpha[1] + sin_t * self.sin_2k_alpha[1],
            ),
            1 => (
                sin_t * self.cos_2k_alpha[0] + cos_t * self.sin_2k_alpha[0],
                cos_t * self.cos_2k_alpha[0] - sin_t * self.sin_2k_alpha[0],
            ),
            2 => (
                sin_t * self.cos_2k_alpha[2] + cos_t * self.sin_2k_alpha[2],
                cos_t * self.cos_2k_alpha[2] - sin_t * self.sin_2k_alpha[2],
            ),
            _ => (sin_t, cos_t),
        };
        (s, c.abs())
    }
}

/// Where the absorption comes from.
#[derive(Debug, Clone)]
pub enum HairAbsorption {
    /// σ_a from the pigment concentrations (a constant).
    Pigments(Spectrum),
    /// `scale · sigma_a`, possibly textured.
    SigmaA {
        /// σ_a per unit radius.
        sigma_a: Texture,
        /// Its multiplier.
        scale: f32,
    },
}

/// Mitsuba `hair` as the scene stores it.
#[derive(Debug, Clone)]
pub struct HairParams {
    /// The lobes' constants.
    pub lobes: HairLobes,
    /// The fibre's absorption.
    pub absorption: HairAbsorption,
}

/// Mitsuba `hair` with its absorption evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct Hair<'a> {
    /// The lobes' constants.
    pub lobes: &'a HairLobes,
    /// Absorption per unit radius, linear RGB.
    pub sigma_a: Spectrum,
}

impl BsdfParams for HairParams {
    type Model<'a> = Hair<'a>;

    #[inline]
    fn at<'a>(&'a self, si: &SurfaceInteraction) -> Hair<'a> {
        let sigma_a = match &self.absorption {
            HairAbsorption::Pigments(s) => *s,
            HairAbsorption::SigmaA { sigma_a, scale } => sigma_a.eval(si) * *scale,
        };
        Hair { lobes: &self.lobes, sigma_a }
    }

    fn textures(&self) -> Vec<&Texture> {
        match &self.absorption {
            HairAbsorption::Pigments(_) => vec![],
            HairAbsorption::SigmaA { sigma_a, .. } => vec![sigma_a],
        }
    }

    /// The fibre's direction is the shading frame's `t` axis.
    fn anisotropic(&self) -> bool {
        true
    }
}

/// d'Eon et al.'s longitudinal scattering M_p / (2π) (Mitsuba's
/// `square_to_rough_fiber_pdf`), with κ = 1/v, for incident and outgoing
/// longitudinal sines.
#[inline]
#[allow(clippy::approx_constant)] // Mitsuba's 0.6931, not ln 2 exactly
fn longitudinal(sin_i: f32, sin_o: f32, v: f32) -> f32 {
    let kappa = 1.0 / v;
    let (cos_i, cos_o) = (safe_sqrt(1.0 - sin_i * sin_i), safe_sqrt(1.0 - sin_o * sin_o));
    let c = cos_i * cos_o * kappa;
    let s = sin_i * sin_o * kappa;
    if kappa > 10.0 {
        (-s + log_i0(c) - kappa + 0.6931 + (0.5 * kappa).ln()).exp() * INV_2PI
    } else {
        (-s).exp() * i0(c) * kappa / (2.0 * kappa.sinh()) * INV_2PI
    }
}

/// The modified Bessel function I₀ by its series (eleven terms, as Mitsuba).
#[inline]
fn i0(x: f32) -> f32 {
    let (mut result, x2) = (1.0f32, x * x);
    let (mut xi, mut denom) = (x2, 4.0f32);
    for i in 1..=10 {
        let factor = i as f32 + 1.0;
        result += xi / denom;
        xi *= x2;
        denom *= 4.0 * factor * factor;
    }
    result
}

/// ln I₀(x), asymptotic for large x.
#[inline]
fn log_i0(x: f32) -> f32 {
    if x > 12.0 {
        x + 0.5 * ((1.0 / (2.0 * PI * x)).ln() + 1.0 / (8.0 * x))
    } else {
        i0(x).ln()
    }
}

#[inline]
fn logistic(x: f32, s: f32) -> f32 {
    let x = x.abs();
    let e = (-x / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

#[inline]
fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic distribution of scale `s` restricted to [−π, π], sampled.
#[inline]
fn trimmed_logistic_sample(u: f32, s: f32) -> f32 {
    let k = logistic_cdf(PI, s) - logistic_cdf(-PI, s);
    let x = -s * (1.0 / (u * k + logistic_cdf(-PI, s)) - 1.0).ln();
    x.clamp(-PI, PI)
}

/// Everything about the camera-side direction the lobes need.
struct Incident {
    sin_theta: f32,
    cos_theta: f32,
    phi: f32,
    gamma: f32,
    gamma_t: f32,
    /// Attenuation of each lobe.
    a_p: [Spectrum; P_MAX + 1],
    /// Each lobe's share of the luminance: its sampling probability.
    a_p_pdf: [f32; P_MAX + 1],
}

impl Hair<'_> {
    /// The incident direction's angles and the lobes' attenuations (Mitsuba's
    /// `attenuation` and `attenuation_pdf`) for `w` on the camera side.
    fn incident(&self, w: Vec3) -> Incident {
        let eta = self.lobes.eta;
        // γ: the angle to the normal within the normal plane, signed by x.
        let proj = safe_sqrt(w.x * w.x + w.z * w.z);
        let g = if proj == 0.0 { 0.0 } else { safe_acos(w.z / proj) };
        let gamma = if w.x < 0.0 { g } else { -g };
        let h = gamma.sin();
        let sin_theta = w.y;
        let cos_theta = safe_sqrt(1.0 - sin_theta * sin_theta);
        let phi = w.z.atan2(w.x);
        // Refraction: longitudinally, and in the normal plane by the modified IOR.
        let sin_theta_t = sin_theta / eta;
        let cos_theta_t = safe_sqrt(1.0 - sin_theta_t * sin_theta_t);
        let eta_p = safe_sqrt(eta * eta - sin_theta * sin_theta) / cos_theta;
        let sin_gamma_t = h / eta_p;
        let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
        let gamma_t = safe_asin(sin_gamma_t);
        let length = 2.0 * cos_gamma_t / cos_theta_t;
        let t = Spectrum::new(
            (-self.sigma_a.x * length).exp(),
            (-self.sigma_a.y * length).exp(),
            (-self.sigma_a.z * length).exp(),
        );
        let cos_gamma_i = safe_sqrt(1.0 - h * h);
        let f = fresnel_dielectric(cos_theta * cos_gamma_i, eta).0;
        let mut a_p = [Spectrum::ZERO; P_MAX + 1];
        a_p[0] = Spectrum::splat(f);
        a_p[1] = t * ((1.0 - f) * (1.0 - f));
        for p in 2..P_MAX {
            a_p[p] = a_p[p - 1] * t * f;
        }
        a_p[P_MAX] = a_p[P_MAX - 1] * t * f / (Spectrum::ONE - t * f);
        let lum = a_p.map(luminance);
        let sum: f32 = lum.iter().sum();
        let a_p_pdf = lum.map(|l| l / sum);
        Incident { sin_theta, cos_theta, phi, gamma, gamma_t, a_p, a_p_pdf }
    }

    /// The trimmed logistic azimuthal distribution of lobe `p` at Δφ.
    #[inline]
    fn azimuthal(&self, delta_phi: f32, p: usize, inc: &Incident) -> f32 {
        let s = self.lobes.s;
        let perfect = 2.0 * p as f32 * inc.gamma_t - 2.0 * inc.gamma + p as f32 * PI;
        // The offset from the perfect interaction, wrapped to [−π, π].
        let mut phi = (delta_phi - perfect) % (2.0 * PI);
        if phi < PI {
            phi += 2.0 * PI;
        }
        if phi > PI {
            phi -= 2.0 * PI;
        }
        logistic(phi, s) / (logistic_cdf(PI, s) - logistic_cdf(-PI, s))
    }

    /// Mitsuba's eval (f times |cos θ| of `wi`, the light side) and pdf;
    /// `wo` is the camera side (Mitsuba's `si.wi`). NaN or infinite results are 0.
    fn eval_pdf_cos(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let inc = self.incident(wo);
        let delta_phi = wi.z.atan2(wi.x) - inc.phi;
        let (mut value, mut pdf) = (Spectrum::ZERO, 0.0f32);
        for p in 0..P_MAX {
            let (sin_ip, _) = self.lobes.reframe(inc.sin_theta, inc.cos_theta, p);
            let m = longitudinal(sin_ip, wi.y, self.lobes.v[p]) * (2.0 * PI) * self.azimuthal(delta_phi, p, &inc);
            value += inc.a_p[p] * m;
            pdf += inc.a_p_pdf[p] * m;
        }
        let m = longitudinal(inc.sin_theta, wi.y, self.lobes.v[P_MAX]);
        value += inc.a_p[P_MAX] * m;
        pdf += inc.a_p_pdf[P_MAX] * m;
        let value = if value.is_finite() { value } else { Spectrum::ZERO };
        let pdf = if pdf.is_finite() { pdf } else { 0.0 };
        (value, pdf)
    }
}

impl BsdfModel for Hair<'_> {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let c = wi.z.abs();
        if c == 0.0 {
            return Spectrum::ZERO;
        }
        self.eval_pdf_cos(wo, wi).0 / c
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf_cos(wo, wi).1
    }

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let inc = self.incident(wo);
        // The lobe, by the luminance of its attenuation; the rest of `u`
        // is rescaled for the azimuth.
        let pdfs = inc.a_p_pdf;
        let (mut p, mut rest, mut u_phi) = (0usize, u, u / pdfs[0]);
        for i in 0..P_MAX {
            let take = pdfs[i] < rest;
            rest -= pdfs[i];
            if take {
                p = i + 1;
                u_phi = rest / pdfs[i + 1];
            }
        }
        let u_phi = u_phi.clamp(0.0, 1.0);
        let (sin_ip, cos_ip) = self.lobes.reframe(inc.sin_theta, inc.cos_theta, p);
        // The longitudinal lobe about the (tilted) mirror angle.
        let v = self.lobes.v[p];
        let cos_theta = (1.0 + v * (u2.x + (1.0 - u2.x) * (-2.0 / v).exp()).ln()).clamp(-1.0, 1.0);
        let sin_theta = safe_sqrt(1.0 - cos_theta * cos_theta);
        let cos_phi = (2.0 * PI * u2.y).cos();
        let sin_theta_o = -cos_theta * sin_ip + sin_theta * cos_phi * cos_ip;
        let cos_theta_o = safe_sqrt(1.0 - sin_theta_o * sin_theta_o);
        let delta_phi = if p < P_MAX {
            2.0 * p as f32 * inc.gamma_t - 2.0 * inc.gamma
                + p as f32 * PI
                + trimmed_logistic_sample(u_phi, self.lobes.s)
        } else {
            2.0 * PI * u_phi
        };
        let (sin_phi_o, cos_phi_o) = (inc.phi + delta_phi).sin_cos();
        let wi = Vec3::new(cos_theta_o * cos_phi_o, sin_theta_o, cos_theta_o * sin_phi_o).normalize();
        let (value, pdf) = self.eval_pdf_cos(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { wi, pdf, weight: value / pdf, delta: false, null: false, eta: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::checks::{check_weights, integrate_sphere_fine};
    use crate::testing::chi2::{chi2_cases, chi2_test};
    use crate::testing::TestRng;

    fn lobes(l: f32, a: f32) -> HairLobes {
        HairLobes::new(l, a, 2.0, 1.55 / 1.000277)
    }

    fn uniform_sphere(u: Vec2) -> Vec3 {
        let z = 1.0 - 2.0 * u.x;
        let r = safe_sqrt(1.0 - z * z);
        let phi = 2.0 * PI * u.y;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    fn cases(ls: &[HairLobes]) -> Vec<(Hair<'_>, Vec3)> {
        let mut v = Vec::new();
        let dirs = [Vec3::new(0.3, 0.2, 0.8), Vec3::new(-0.6, -0.5, 0.3), Vec3::new(0.1, 0.9, -0.4)];
        for (k, l) in ls.iter().enumerate() {
            let sigma_a = [Spectrum::new(0.2, 0.5, 1.2), Spectrum::splat(0.05), Spectrum::new(1.9, 2.6, 4.0)][k % 3];
            for d in dirs {
                v.push((Hair { lobes: l, sigma_a }, d.normalize()));
            }
        }
        v
    }

    fn all_lobes() -> Vec<HairLobes> {
        vec![lobes(0.3, 0.3), lobes(0.15, 0.6), lobes(0.6, 0.2)]
    }

    #[test]
    fn sampling_matches_pdf() {
        let ls = all_lobes();
        let cases = cases(&ls);
        let a = chi2_cases(
            "hair",
            300_000,
            1100,
            &cases,
            |b, wo, u1, u| b.sample(wo, u1, u).map(|s| s.wi),
            |b, wo, wi| b.pdf(wo, wi) as f64,
        );
        // Power: Mitsuba 3.9.1's sampler of the longer paths (every p = 3
        // sample in the fibre's normal plane) against the same pdf, on a
        // lightly absorbing fibre where that lobe is likely.
        let (b, wo) = (Hair { lobes: &ls[0], sigma_a: Spectrum::splat(0.02) }, cases[0].1);
        let inc = b.incident(wo);
        println!("hair p = 3 probability {}", inc.a_p_pdf[3]);
        let p = chi2_test(
            300_000,
            1099,
            |u1, u| {
                let s = b.sample(wo, u1, u)?;
                let last = 1.0 - inc.a_p_pdf[3];
                if u1 > last {
                    let phi = s.wi.z.atan2(s.wi.x);
                    Some(Vec3::new(phi.cos(), 0.0, phi.sin()))
                } else {
                    Some(s.wi)
                }
            },
            |wi| b.pdf(wo, wi) as f64,
        );
        println!("hair with Mitsuba's p = 3 sampling: p = {p:.3e}");
        assert!(p < a, "a sampler off its pdf was accepted: p = {p}");
    }

    #[test]
    fn pdf_integrates_to_one_and_weights_match() {
        let ls = all_lobes();
        for (b, wo) in cases(&ls) {
            let total = integrate_sphere_fine(1200, 600, |wi| b.pdf(wo, wi) as f64);
            assert!((total - 1.0).abs() < 3e-3, "∫ pdf = {total} for wo {wo}");
            let wos = [wo, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.7, -0.1, -0.7).normalize()];
            check_weights(3, &wos, |wo, u, u2| b.sample(wo, u, u2), |wo, wi| b.eval(wo, wi), |wo, wi| b.pdf(wo, wi));
        }
    }

    /// Without absorption the fibre loses nothing: ∫ f |cos| dω = 1 (Mitsuba's
    /// white furnace test), and each sample's weight has luminance 1.
    #[test]
    fn white_furnace() {
        let ls = [lobes(0.1, 0.1), lobes(0.3, 0.3), lobes(0.99, 0.5), lobes(0.5, 0.99)];
        let mut rng = TestRng::new(17);
        for l in &ls {
            let b = Hair { lobes: l, sigma_a: Spectrum::ZERO };
            for _ in 0..4 {
                let wo = uniform_sphere(rng.next_2d());
                let total = integrate_sphere_fine(1200, 600, |wi| (b.eval(wo, wi).x * wi.z.abs()) as f64);
                assert!((total - 1.0).abs() < 5e-3, "{l:?} wo {wo}: ∫ f cos = {total}");
                for _ in 0..200 {
                    if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                        assert!((luminance(s.weight) - 1.0).abs() < 1e-3, "{:?}", s.weight);
                    }
                }
            }
        }
    }

    // Mitsuba 3.9.1 (scalar_rgb) by tools/mitsuba_bsdf_values.py: eval (with
    // Mitsuba's cosine) and pdf of `hair` in the frame (x, y, z) = (s, t, n),
    // camera side wo = normalize(0.3, 0.2, 0.8). Tolerance 2e-4 relative:
    // f32 evaluations of the same formulas (atan2, exp and the Bessel series
    // round differently).
    #[test]
    fn matches_mitsuba() {
        let wo = Vec3::new(0.3, 0.2, 0.8).normalize();
        let cases: [(f32, f32, f32, Option<Spectrum>, Vec3, [f32; 3], f32); 4] = [
            (0.3, 0.3, 2.0, None, Vec3::new(-0.5, 0.1, 0.6), [0.0175971, 0.01759087, 0.01759018], 0.08613107),
            (0.3, 0.3, 2.0, None, Vec3::new(-0.2, -0.3, -0.9), [1.253891, 0.565493, 0.07802188], 3.313194),
            (
                0.1,
                0.5,
                5.0,
                Some(Spectrum::new(0.2, 0.3, 0.5)),
                Vec3::new(-0.5, -0.25, 0.6),
                [0.005609755, 0.004666197, 0.003382462],
                0.008294556,
            ),
            (
                0.7,
                0.2,
                0.0,
                Some(Spectrum::new(0.05, 0.05, 0.1)),
                Vec3::new(0.4, 0.3, -0.8),
                [0.001034293, 0.001034293, 0.0009169965],
                0.001139143,
            ),
        ];
        for (l, a, tilt, sigma_a, wi, e, p) in cases {
            let lobes = HairLobes::new(l, a, tilt, 1.55 / 1.000277);
            let sigma_a = sigma_a.unwrap_or(EUMELANIN_SIGMA_A * 1.3 + PHEOMELANIN_SIGMA_A * 0.2);
            let b = Hair { lobes: &lobes, sigma_a };
            let wi = wi.normalize();
            let ours = b.eval(wo, wi) * wi.z.abs();
            let e = Spectrum::from(e);
            println!("hair {l}/{a}/{tilt}: eval·cos {ours} vs Mitsuba {e}; pdf {} vs {p}", b.pdf(wo, wi));
            assert!(((ours - e) / e).abs().max_element() < 2e-4, "{ours} vs Mitsuba {e}");
            assert!((b.pdf(wo, wi) / p - 1.0).abs() < 2e-4, "{} vs Mitsuba {p}", b.pdf(wo, wi));
        }
    }
}
