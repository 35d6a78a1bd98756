//! Mitsuba `plastic`: a diffuse base under a smooth dielectric coating,
//! with internal scattering between them accounted for in closed form.
//!
//! | parameter            | type          | default |
//! |----------------------|---------------|---------|
//! | diffuse_reflectance  | rgb/texture   | 0.5     |
//! | specular_reflectance | rgb/texture   | 1       |
//! | int_ior              | float or name | polypropylene (1.49) |
//! | ext_ior              | float or name | air     |
//! | nonlinear            | boolean       | false   |
//!
//! The diffuse lobe is ρ/(1 − F_dr,int) · (1 − F(θ_i))(1 − F(θ_o)) / (π η²)
//! (Weidlich & Wilkie 2007; `nonlinear` uses ρ/(1 − ρ F_dr,int)); the
//! specular lobe is a Fresnel-weighted mirror.

use super::fresnel::{fresnel_dielectric, reflect};
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, INV_PI};
use crate::sampling::warp;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Copy)]
pub struct Plastic {
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    pub diffuse_reflectance: Spectrum,
    pub specular_reflectance: Spectrum,
    pub nonlinear: bool,
    /// Diffuse Fresnel reflectance seen from inside, F_dr(1/η).
    pub fdr_int: f32,
    /// s_mean / (d_mean + s_mean) of the reflectances' means, as Mitsuba.
    pub specular_sampling_weight: f32,
}

/// Mitsuba `plastic` as the scene stores it.
#[derive(Debug, Clone)]
pub struct PlasticParams {
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    pub diffuse_reflectance: Texture,
    pub specular_reflectance: Texture,
    pub nonlinear: bool,
    /// F_dr(1/η), precomputed from `eta`.
    pub fdr_int: f32,
    /// As the model's, from the reflectances' means.
    pub specular_sampling_weight: f32,
}

impl BsdfParams for PlasticParams {
    type Model<'a> = Plastic;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> Plastic {
        Plastic {
            eta: self.eta,
            diffuse_reflectance: self.diffuse_reflectance.eval(si),
            specular_reflectance: self.specular_reflectance.eval(si),
            nonlinear: self.nonlinear,
            fdr_int: self.fdr_int,
            specular_sampling_weight: self.specular_sampling_weight,
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.diffuse_reflectance, &self.specular_reflectance]
    }
}

/// Hemispherical average of the dielectric Fresnel reflectance for diffuse
/// incidence: fits by Egan & Hilgeman (1973) for η < 1 and d'Eon & Irving
/// (2011) otherwise, as Mitsuba.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &k| acc * inv + k)
    }
}

impl Plastic {
    #[inline]
    fn prob_specular(&self, f_i: f32) -> f32 {
        let s = f_i * self.specular_sampling_weight;
        let d = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        s / (s + d)
    }

    /// The diffuse albedo after internal reflections in the coating.
    #[inline]
    fn diffuse(&self) -> Spectrum {
        let d = self.diffuse_reflectance;
        if self.nonlinear {
            d / (Spectrum::ONE - d * self.fdr_int)
        } else {
            d / (1.0 - self.fdr_int)
        }
    }
}

impl BsdfModel for Plastic {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let f_o = fresnel_dielectric(wi.z, self.eta).0;
        self.diffuse() * (INV_PI / (self.eta * self.eta) * (1.0 - f_i) * (1.0 - f_o))
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        (1.0 - self.prob_specular(f_i)) * warp::cosine_hemisphere_pdf(wi)
    }

    #[inline]
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let p_spec = self.prob_specular(f_i);
        if u < p_spec {
            return Some(BsdfSample {
                wi: reflect(wo),
                pdf: p_spec,
                weight: self.specular_reflectance * (f_i / p_spec),
                delta: true,
                eta: 1.0,
            });
        }
        let wi = warp::sample_cosine_hemisphere(u2);
        let pdf = (1.0 - p_spec) * warp::cosine_hemisphere_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        let f_o = fresnel_dielectric(wi.z, self.eta).0;
        let weight = self.diffuse() * ((1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta * (1.0 - p_spec)));
        Some(BsdfSample { wi, pdf, weight, delta: false, eta: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::TestRng as Rng;

    fn plastic(d: f32, nonlinear: bool) -> Plastic {
        let eta = 1.49;
        Plastic {
            eta,
            diffuse_reflectance: Spectrum::splat(d),
            specular_reflectance: Spectrum::ONE,
            nonlinear,
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight: 1.0 / (d + 1.0),
        }
    }

    /// F_dr by quadrature: 2 ∫ F(cos θ) cos θ sin θ dθ.
    fn fdr_numeric(eta: f32) -> f32 {
        let n = 20_000;
        (0..n)
            .map(|i| {
                let c = (i as f64 + 0.5) / n as f64;
                2.0 * fresnel_dielectric(c as f32, eta).0 as f64 * c / n as f64
            })
            .sum::<f64>() as f32
    }

    #[test]
    fn diffuse_fresnel_fits_match_quadrature() {
        for eta in [1.2f32, 1.49, 1.8, 1.0 / 1.33, 1.0 / 1.49] {
            let (fit, num) = (fresnel_diffuse_reflectance(eta), fdr_numeric(eta));
            assert!((fit - num).abs() < 0.006 * num.max(0.05), "eta {eta}: fit {fit} vs {num}");
        }
    }

    /// The diffuse lobe's samples follow pdf(); the specular (delta) lobe is
    /// chosen with the remaining probability, so the pdf integrates to it.
    #[test]
    fn chi2_diffuse_lobe_matches_pdf() {
        use crate::testing::chi2::{alpha, chi2_test, integrate_over_sphere};
        let cases = [(0.5f32, 1.0f32), (0.8, 0.5), (0.1, 0.05), (0.9, 0.02)];
        let a = alpha(cases.len() + 1);
        for (k, (d, cos)) in cases.into_iter().enumerate() {
            let b = plastic(d, k % 2 == 1);
            let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let p = chi2_test(
                400_000,
                100 + k as u64,
                |u1, u2| b.sample(wo, u1, u2).filter(|s| !s.delta).map(|s| s.wi),
                |wi| b.pdf(wo, wi) as f64,
            );
            assert!(p > a, "plastic d={d} cos={cos}: p = {p}");
            let f_i = fresnel_dielectric(cos, b.eta).0;
            let total = integrate_over_sphere(|wi| b.pdf(wo, wi) as f64);
            assert!((total - (1.0 - b.prob_specular(f_i)) as f64).abs() < 5e-3, "∫ pdf = {total}");
        }
        // Power: a uniform-hemisphere pdf with the same total must fail.
        let b = plastic(0.5, false);
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let scale = 1.0 - b.prob_specular(fresnel_dielectric(0.8, b.eta).0);
        let p = chi2_test(
            400_000,
            120,
            |u1, u2| b.sample(wo, u1, u2).filter(|s| !s.delta).map(|s| s.wi),
            |wi| if wi.z > 0.0 { (scale * 0.5 * INV_PI) as f64 } else { 0.0 },
        );
        assert!(p < a, "a wrong pdf passed: p = {p}");
    }

    #[test]
    fn sampling_weights_agree_with_eval_over_pdf() {
        let b = plastic(0.6, false);
        let mut rng = Rng::new(7);
        for _ in 0..1000 {
            let wo = warp::sample_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            if let Some(s) = b.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) {
                if !s.delta {
                    let expect = b.eval(wo, s.wi) * s.wi.z / b.pdf(wo, s.wi);
                    assert!((s.weight - expect).abs().max_element() < 1e-4 * expect.max_element().max(1.0));
                    assert!((s.pdf - b.pdf(wo, s.wi)).abs() < 1e-4 * s.pdf);
                }
            }
        }
    }

    #[test]
    fn albedo_at_most_one_and_reciprocal() {
        // A white base: the linear model may only lose energy (it ignores the
        // base's re-reflection in the albedo's denominator's numerator).
        for nonlinear in [false, true] {
            let b = plastic(1.0 - 1e-3, nonlinear);
            for c in [1.0f32, 0.6, 0.2] {
                let wo = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
                let n = 200_000;
                let mut rng = Rng::new(3);
                let mut sum = 0.0f64;
                for _ in 0..n {
                    if let Some(s) = b.sample(wo, rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32())) {
                        sum += s.weight.x as f64;
                    }
                }
                let albedo = sum / n as f64;
                if !nonlinear {
                    assert!(albedo < 1.0 + 0.01, "albedo {albedo} at cos {c}");
                }
                assert!(albedo > 0.5, "albedo {albedo} at cos {c}");
            }
        }
        let b = plastic(0.5, false);
        let (a, c) = (Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(-0.6, 0.2, 0.3).normalize());
        assert!((b.eval(a, c) - b.eval(c, a)).abs().max_element() < 1e-6);
    }
}
