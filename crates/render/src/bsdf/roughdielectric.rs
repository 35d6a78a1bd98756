//! Mitsuba `roughdielectric` (Walter et al. 2007): microfacet reflection and
//! refraction at a rough interface, two-sided (η is inverted when `wo` is
//! inside), radiance transport mode (refraction scaled by 1/η² of the side
//! entered). Sampling: a visible normal of `wo` (mirrored to the upper
//! hemisphere), then reflection with probability F(dot(wo, m)), else
//! refraction.

use super::fresnel::fresnel_dielectric;
use super::microfacet::Roughness;
use super::microfacet::{reflect_m, refract_m, Microfacet};
use super::{mulsign, BsdfSample};
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `roughdielectric` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct RoughDielectric {
    /// Microfacet distribution of the surface.
    pub distr: Microfacet,
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Spectrum,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Spectrum,
}

/// Mitsuba `roughdielectric` as the scene stores it.
#[derive(Debug, Clone)]
pub struct RoughDielectricParams {
    /// Roughness (α, isotropic or anisotropic) and distribution.
    pub roughness: Roughness,
    /// Relative IOR (interior / exterior).
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Texture,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Texture,
}

impl BsdfParams for RoughDielectricParams {
    type Model<'a> = RoughDielectric;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> RoughDielectric {
        RoughDielectric {
            distr: self.roughness.at(si),
            eta: self.eta,
            specular_reflectance: self.specular_reflectance.eval(si),
            specular_transmittance: self.specular_transmittance.eval(si),
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.roughness.alpha_u, &self.roughness.alpha_v, &self.specular_reflectance, &self.specular_transmittance]
    }

    fn anisotropic(&self) -> bool {
        self.roughness.anisotropic()
    }
}

impl RoughDielectric {
    /// The generalized half vector of (wo, wi), in the upper hemisphere,
    /// whether this is a reflection, and η of the side of `wi` relative to `wo`'s.
    #[inline]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> (Vec3, bool, f32) {
        let reflect = wo.z * wi.z > 0.0;
        let eta = if wo.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let m = (wo + wi * if reflect { 1.0 } else { eta }).normalize();
        (mulsign(m, m.z), reflect, eta)
    }
}

impl BsdfModel for RoughDielectric {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return Spectrum::ZERO;
        }
        let (m, reflect, eta) = self.half_vector(wo, wi);
        if !m.is_finite() {
            return Spectrum::ZERO;
        }
        let d = self.distr.eval(m);
        if d == 0.0 {
            return Spectrum::ZERO;
        }
        let g = self.distr.g(wo, wi, m);
        let f = fresnel_dielectric(wo.dot(m), self.eta).0;
        if reflect {
            self.specular_reflectance * (f * d * g / (4.0 * cos_o.abs() * cos_i.abs()))
        } else {
            // Radiance mode: the solid-angle compression factor 1/η².
            let (dom, dim) = (wo.dot(m), wi.dot(m));
            let denom = dom + eta * dim;
            let value = ((1.0 - f) * d * g * dom * dim / (cos_o * cos_i * denom * denom)).abs();
            self.specular_transmittance * value
        }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return 0.0;
        }
        let (m, reflect, eta) = self.half_vector(wo, wi);
        if !m.is_finite() {
            return 0.0;
        }
        let (dom, dim) = (wo.dot(m), wi.dot(m));
        if dom * cos_o <= 0.0 || dim * cos_i <= 0.0 {
            return 0.0;
        }
        let dwh_dwi = if reflect { 1.0 / (4.0 * dim) } else { eta * eta * dim / (dom + eta * dim).powi(2) };
        let f = fresnel_dielectric(dom, self.eta).0;
        let prob = self.distr.pdf(mulsign(wo, cos_o), m) * if reflect { f } else { 1.0 - f };
        prob * dwh_dwi.abs()
    }

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let cos_o = wo.z;
        if cos_o == 0.0 {
            return None;
        }
        let (m, pdf_m) = self.distr.sample(mulsign(wo, cos_o), u2);
        if pdf_m == 0.0 {
            return None;
        }
        let dom = wo.dot(m);
        let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(dom, self.eta);
        let (wi, mut weight, mut pdf, eta, dwh_dwi);
        if u <= f {
            wi = reflect_m(wo, m);
            weight = self.specular_reflectance;
            pdf = pdf_m * f;
            eta = 1.0;
            dwh_dwi = 1.0 / (4.0 * wi.dot(m));
        } else {
            wi = refract_m(wo, m, cos_t, eta_ti);
            weight = self.specular_transmittance * (eta_ti * eta_ti);
            pdf = pdf_m * (1.0 - f);
            eta = eta_it;
            let dim = wi.dot(m);
            dwh_dwi = eta_it * eta_it * dim / (dom + eta_it * dim).powi(2);
        }
        // Zero when wi landed on the wrong side of the macro- or microsurface.
        let g1 = self.distr.smith_g1(wi, m);
        if g1 == 0.0 {
            return None;
        }
        weight *= g1;
        pdf *= dwh_dwi.abs();
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { wi, pdf, weight, delta: false, null: false, eta })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::checks::{albedo, check_weights, dir, integrate_sphere_fine};
    use crate::bsdf::MicrofacetType::{self, Beckmann, Ggx};
    use crate::testing::chi2::{chi2_cases, chi2_test};

    fn dielectric(kind: MicrofacetType, au: f32, av: f32) -> RoughDielectric {
        RoughDielectric {
            distr: Microfacet { kind, alpha_u: au, alpha_v: av },
            eta: 1.5,
            specular_reflectance: Spectrum::ONE,
            specular_transmittance: Spectrum::ONE,
        }
    }

    /// Outside at several angles, and inside: above and below the critical
    /// angle (cos 0.745 for η = 1.5), and deep in total internal reflection.
    fn wos() -> [Vec3; 6] {
        [dir(0.9, 0.7), dir(0.4, 2.0), dir(0.05, -1.0), dir(-0.9, 0.3), dir(-0.7, 1.2), dir(-0.2, -2.5)]
    }

    fn cases() -> Vec<(RoughDielectric, Vec3)> {
        let mut v = Vec::new();
        for kind in [Beckmann, Ggx] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                for wo in wos() {
                    v.push((dielectric(kind, au, av), wo));
                }
            }
        }
        v
    }

    #[test]
    fn sampling_matches_pdf() {
        let a = chi2_cases(
            "roughdielectric",
            120_000,
            500,
            &cases(),
            |b, wo, u1, u| b.sample(wo, u1, u).map(|s| s.wi),
            |b, wo, wi| b.pdf(wo, wi) as f64,
        );
        // Power: a pdf that forgets the Fresnel lobe selection (reflection
        // and refraction each at full density, halved) must be rejected.
        let (b, wo) = (dielectric(Ggx, 0.3, 0.3), dir(0.3, 0.0));
        let p = chi2_test(
            150_000,
            499,
            |u1, u| b.sample(wo, u1, u).map(|s| s.wi),
            |wi| {
                let (m, reflect, _) = b.half_vector(wo, wi);
                let f = fresnel_dielectric(wo.dot(m), b.eta).0 as f64;
                let p = b.pdf(wo, wi) as f64;
                if p == 0.0 {
                    0.0
                } else if reflect {
                    p / f * 0.5
                } else {
                    p / (1.0 - f) * 0.5
                }
            },
        );
        println!("roughdielectric wrong pdf: p = {p:.3e}");
        assert!(p < a, "wrong pdf accepted: p = {p}");
    }

    #[test]
    fn pdf_integrates_to_sample_probability() {
        for (b, wo) in cases() {
            if b.distr.alpha_u < 0.1 && wo.z.abs() < 0.3 {
                // Lobes a few 1e-3 rad thin: left to the chi-square test.
                continue;
            }
            let n = 100_000;
            let mut rng = crate::testing::TestRng::new(5);
            let hits = (0..n).filter(|_| b.sample(wo, rng.next_f32(), rng.next_2d()).is_some()).count();
            let prob = hits as f64 / n as f64;
            let total = integrate_sphere_fine(2000, 400, |wi| b.pdf(wo, wi) as f64);
            let tol = 3.0 * (prob * (1.0 - prob) / n as f64).sqrt() + 4e-3;
            assert!((total - prob).abs() < tol, "{:?} wo={wo}: ∫ pdf = {total}, P(sample) = {prob}", b.distr);
        }
    }

    #[test]
    fn weights_are_eval_cos_over_pdf() {
        for (b, _) in cases() {
            let n = check_weights(
                8,
                &wos(),
                |wo, u, u2| b.sample(wo, u, u2),
                |wo, wi| b.eval(wo, wi),
                |wo, wi| b.pdf(wo, wi),
            );
            assert!(n > 8000, "{n}");
        }
        // The sampled η: that of the side entered, 1 for reflection.
        let b = dielectric(Ggx, 0.3, 0.3);
        let mut rng = crate::testing::TestRng::new(2);
        for wo in wos() {
            for _ in 0..500 {
                if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                    let expect = if s.wi.z * wo.z > 0.0 {
                        1.0
                    } else if wo.z > 0.0 {
                        1.5
                    } else {
                        1.0 / 1.5
                    };
                    assert_eq!(s.eta, expect);
                }
            }
        }
    }

    /// Radiance mode obeys the generalized reciprocity
    /// f(wo, wi) / n(wo)² = f(wi, wo) / n(wi)², with n(w) = 1 for a direction
    /// outside and η inside (plain symmetry for reflection).
    #[test]
    fn reciprocity() {
        let mut rng = crate::testing::TestRng::new(13);
        let n2 = |w: Vec3| if w.z > 0.0 { 1.0 } else { 1.5f32 * 1.5 };
        for (b, _) in cases() {
            for _ in 0..300 {
                let a = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
                let c = dir(2.0 * rng.next_f32() - 1.0, 6.3 * rng.next_f32());
                let (f1, f2) = (b.eval(a, c) / n2(a), b.eval(c, a) / n2(c));
                // f32 cancellation in dot(wo, m) + η dot(wi, m) near grazing
                // refraction limits the agreement to ~1e-3.
                assert!(
                    (f1 - f2).abs().max_element() <= 5e-3 * f1.max_element().max(1e-2),
                    "{:?} {a} {c}: {f1} vs {f2}",
                    b.distr
                );
            }
        }
    }

    /// Energy: the mean sample weight (radiance mode) equals ∫ f |cos| dω by
    /// quadrature of eval(), and the mean of the unscaled (importance) weights
    /// is at most 1: transmission from outside carries 1/η² in radiance mode.
    #[test]
    fn albedo_matches_quadrature_and_is_bounded() {
        for kind in [Beckmann, Ggx] {
            for (au, av) in [(0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                let b = dielectric(kind, au, av);
                for wo in [dir(0.9, 0.7), dir(0.3, 2.0), dir(-0.9, 0.3), dir(-0.5, 1.0)] {
                    let (mean, se) = albedo(200_000, 31, wo, |wo, u, u2| b.sample(wo, u, u2));
                    let quad = integrate_sphere_fine(1500, 300, |wi| (b.eval(wo, wi).x * wi.z.abs()) as f64);
                    // Importance-mode albedo: undo the radiance scale of refractions.
                    let (imp, ise) = albedo(200_000, 31, wo, |wo, u, u2| {
                        b.sample(wo, u, u2).map(|s| BsdfSample { weight: s.weight * s.eta * s.eta, ..s })
                    });
                    println!("{kind:?} {au}/{av} wo.z {:.2}: albedo {mean:.4} ± {se:.4}, quadrature {quad:.4}, importance {imp:.4}", wo.z);
                    assert!((mean - quad).abs() < 4.0 * se + 3e-3, "MC {mean} vs quadrature {quad}");
                    assert!(imp <= 1.0 + 4.0 * ise, "importance albedo {imp}");
                }
            }
        }
    }

    // Generated with Mitsuba 3.9.1 (scalar_rgb), for each case:
    //   b = mi.load_dict(d); si = mi.SurfaceInteraction3f(); si.wi = wo
    //   si.sh_frame = mi.Frame3f([0, 0, 1]); ctx = mi.BSDFContext()
    //   b.eval(ctx, si, wi), b.pdf(ctx, si, wi)
    // with wo = normalize(0.3, 0.2, 0.8), wi_r = normalize(-0.5, 0.1, 0.6),
    // wi_t = normalize(-0.4, -0.3, -0.7), wi_g = normalize(0.9, -0.2, 0.1).
    // Mitsuba's eval includes |cos θ_i|.
    // d = {'type': 'roughdielectric', 'distribution': 'ggx', 'alpha': α, 'int_ior': 1.5, 'ext_ior': 1.0}
    // (or 'alpha_u': 0.2, 'alpha_v': 0.6), cases (wo, wi) as below.
    #[test]
    fn matches_mitsuba() {
        let wo = Vec3::new(0.3418817, 0.2279212, 0.9116846);
        let wi_r = Vec3::new(-0.6350006, 0.1270001, 0.7620008);
        let wi_t = Vec3::new(-0.4649906, -0.3487429, -0.8137335);
        let cases = [
            (0.3, 0.3, wo, wi_r, 0.01346177, 0.01367708),
            (0.3, 0.3, wo, wi_t, 0.1467454, 0.333925),
            (0.2, 0.6, wi_t, wo, 0.1366954, 0.06117775),
            (0.5, 0.5, -wi_r, -wo, 0.01469893, 0.01488322),
        ];
        for (au, av, a, c, e, p) in cases {
            let b = RoughDielectric {
                distr: Microfacet { kind: Ggx, alpha_u: au, alpha_v: av },
                ..dielectric(Ggx, au, av)
            };
            let ours = b.eval(a, c).x * c.z.abs();
            assert!((ours / e - 1.0).abs() < 1e-3, "{a} {c}: {ours} vs Mitsuba {e}");
            assert!((b.pdf(a, c) / p - 1.0).abs() < 1e-3, "{a} {c}: {} vs Mitsuba {p}", b.pdf(a, c));
        }
    }
}
