//! pbrt-v4 `diffusetransmission`: Lambertian reflection R/π on the side of
//! `wo` and Lambertian transmission T/π to the other side, two-sided by
//! nature. Sampling picks reflection with probability
//! max(R) / (max(R) + max(T)) (pbrt-v4's choice), then a cosine-weighted
//! direction on that side.
//!
//! | parameter     | type    | default |
//! |---------------|---------|---------|
//! | reflectance   | texture | 0.25    |
//! | transmittance | texture | 0.25    |
//! | scale         | float   | 1: both multiplied by it, then clamped to [0, 1] (as pbrt-v4) |

use super::{BsdfModel, BsdfParams, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, INV_PI};
use crate::sampling::warp;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// The model at a hit.
#[derive(Debug, Clone, Copy)]
pub struct DiffuseTransmission {
    /// R: reflected albedo.
    pub reflectance: Spectrum,
    /// T: transmitted albedo.
    pub transmittance: Spectrum,
}

/// As the scene stores it.
#[derive(Debug, Clone)]
pub struct DiffuseTransmissionParams {
    /// R before scaling.
    pub reflectance: Texture,
    /// T before scaling.
    pub transmittance: Texture,
    /// Multiplies both.
    pub scale: f32,
}

impl BsdfParams for DiffuseTransmissionParams {
    type Model<'a> = DiffuseTransmission;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> DiffuseTransmission {
        let f = |t: &Texture| (t.eval(si) * self.scale).clamp(Vec3::ZERO, Vec3::ONE);
        DiffuseTransmission { reflectance: f(&self.reflectance), transmittance: f(&self.transmittance) }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.reflectance, &self.transmittance]
    }
}

impl DiffuseTransmission {
    /// Probability of sampling reflection (`None` when both lobes are black).
    #[inline]
    fn p_reflect(&self) -> Option<f32> {
        let (pr, pt) = (self.reflectance.max_element(), self.transmittance.max_element());
        (pr + pt > 0.0).then(|| pr / (pr + pt))
    }
}

impl BsdfModel for DiffuseTransmission {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z == 0.0 || wi.z == 0.0 {
            Spectrum::ZERO
        } else if (wo.z > 0.0) == (wi.z > 0.0) {
            self.reflectance * INV_PI
        } else {
            self.transmittance * INV_PI
        }
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(pr) = self.p_reflect() else { return 0.0 };
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        let side = if (wo.z > 0.0) == (wi.z > 0.0) { pr } else { 1.0 - pr };
        side * wi.z.abs() * INV_PI
    }

    /// Weight f |cos| / p = R / P(reflect) or T / P(transmit).
    #[inline]
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let pr = self.p_reflect()?;
        if wo.z == 0.0 {
            return None;
        }
        let mut wi = warp::sample_cosine_hemisphere(u2);
        let reflect = u < pr;
        // Reflection stays on wo's side, transmission crosses.
        if (wo.z < 0.0) == reflect {
            wi.z = -wi.z;
        }
        let (albedo, p) = if reflect { (self.reflectance, pr) } else { (self.transmittance, 1.0 - pr) };
        let pdf = p * wi.z.abs() * INV_PI;
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample { wi, pdf, weight: albedo / p, delta: false, null: false, eta: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, BsdfKind};
    use crate::testing::chi2::{alpha, chi2_test};

    fn model(r: f32, t: f32) -> Bsdf<'static> {
        Bsdf::from(BsdfKind::DiffuseTransmission(DiffuseTransmission {
            reflectance: Vec3::new(r, 0.5 * r, 0.2 * r),
            transmittance: Vec3::new(0.3 * t, t, 0.6 * t),
        }))
    }

    #[test]
    fn sampling_matches_the_pdf_and_weights_are_f_cos_over_pdf() {
        let a = alpha(6);
        let mut k = 0;
        for (r, t) in [(0.4, 0.6), (0.9, 0.05), (0.0, 0.7)] {
            let b = model(r, t);
            for wo in [Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(0.2, -0.5, -0.6).normalize()] {
                k += 1;
                let p =
                    chi2_test(400_000, 60 + k, |u1, u| b.sample(wo, u1, u).map(|s| s.wi), |wi| b.pdf(wo, wi) as f64);
                assert!(p > a, "R {r} T {t} wo {wo}: p = {p}");
                for j in 0..64 {
                    let (u1, u2) = ((j as f32 + 0.5) / 64.0, Vec2::new(0.37, (j % 7) as f32 / 7.0 + 0.05));
                    let s = b.sample(wo, u1, u2).unwrap();
                    let expect = b.eval(wo, s.wi) * s.wi.z.abs() / s.pdf;
                    assert!((s.weight - expect).abs().max_element() < 1e-5, "{} vs {expect}", s.weight);
                }
            }
        }
        // Power: a pdf ignoring the lobe probabilities is rejected.
        let b = model(0.9, 0.05);
        let wo = Vec3::Z;
        let p =
            chi2_test(400_000, 70, |u1, u| b.sample(wo, u1, u).map(|s| s.wi), |wi| (0.5 * wi.z.abs() * INV_PI) as f64);
        assert!(p < a, "equal-lobe pdf accepted (p = {p})");
    }

    #[test]
    fn white_furnace_reflects_and_transmits_r_plus_t() {
        // ∫ f |cos| dω over the sphere = R + T, estimated by the sampler's weights.
        let (r, t) = (Vec3::splat(0.35), Vec3::splat(0.65));
        let b = Bsdf::from(BsdfKind::DiffuseTransmission(DiffuseTransmission { reflectance: r, transmittance: t }));
        let n = 64 * 64;
        let mut acc = Vec3::ZERO;
        for i in 0..n {
            let u2 = Vec2::new(((i % 64) as f32 + 0.5) / 64.0, ((i / 64) as f32 + 0.5) / 64.0);
            let u1 = ((i * 37 % n) as f32 + 0.5) / n as f32;
            acc += b.sample(Vec3::new(0.1, 0.2, -0.97).normalize(), u1, u2).map_or(Vec3::ZERO, |s| s.weight);
        }
        let mean = acc / n as f32;
        assert!((mean - Vec3::ONE).abs().max_element() < 1e-3, "{mean}");
        // Black lobes: nothing to sample, nothing to evaluate.
        let black = model(0.0, 0.0);
        assert!(black.sample(Vec3::Z, 0.5, Vec2::splat(0.5)).is_none());
        assert_eq!(black.pdf(Vec3::Z, -Vec3::Z), 0.0);
    }
}
