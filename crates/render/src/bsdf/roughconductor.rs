//! Mitsuba `roughconductor`: a Torrance–Sparrow microfacet conductor,
//! f = F(dot(wo, h)) D(h) G(wo, wi, h) / (4 cos θ_o cos θ_i) · specular_reflectance,
//! one-sided, sampled by reflecting visible normals of `wo`.

use super::fresnel::fresnel_conductor;
use super::microfacet::Roughness;
use super::microfacet::{reflect_m, Microfacet};
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `roughconductor` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct RoughConductor {
    /// Microfacet distribution of the surface.
    pub distr: Microfacet,
    /// Real part of the relative complex IOR, per channel.
    pub eta: Spectrum,
    /// Imaginary part (absorption) of the relative complex IOR, per channel.
    pub k: Spectrum,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Spectrum,
}

/// Mitsuba `roughconductor` as the scene stores it.
#[derive(Debug, Clone)]
pub struct RoughConductorParams {
    /// Roughness (α, isotropic or anisotropic) and distribution.
    pub roughness: Roughness,
    /// Real part of the relative complex IOR.
    pub eta: Texture,
    /// Imaginary part (absorption) of the relative complex IOR.
    pub k: Texture,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Texture,
}

impl BsdfParams for RoughConductorParams {
    type Model<'a> = RoughConductor;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> RoughConductor {
        RoughConductor {
            distr: self.roughness.at(si),
            eta: self.eta.eval(si),
            k: self.k.eval(si),
            specular_reflectance: self.specular_reflectance.eval(si),
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.roughness.alpha_u, &self.roughness.alpha_v, &self.eta, &self.k, &self.specular_reflectance]
    }

    fn anisotropic(&self) -> bool {
        self.roughness.anisotropic()
    }
}

impl BsdfModel for RoughConductor {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let h = (wo + wi).normalize();
        let d = self.distr.eval(h);
        if d == 0.0 {
            return Spectrum::ZERO;
        }
        let g = self.distr.g(wo, wi, h);
        let f = fresnel_conductor(wo.dot(h), self.eta, self.k);
        f * self.specular_reflectance * (d * g / (4.0 * wo.z * wi.z))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        if wo.dot(m) <= 0.0 || wi.dot(m) <= 0.0 {
            return 0.0;
        }
        // D_wo(m) / (4 dot(wi, m)) with dot(wi, m) = dot(wo, m).
        self.distr.eval(m) * self.distr.smith_g1(wo, m) / (4.0 * wo.z)
    }

    fn sample(&self, wo: Vec3, _u: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (m, pdf_m) = self.distr.sample(wo, u2);
        let wi = reflect_m(wo, m);
        if pdf_m == 0.0 || wi.z <= 0.0 {
            return None;
        }
        let g1 = self.distr.smith_g1(wi, m);
        if g1 == 0.0 {
            return None;
        }
        let pdf = pdf_m / (4.0 * wi.dot(m));
        // Visible-normal sampling: D G1(wo) cancels, leaving F G1(wi).
        let weight = fresnel_conductor(wo.dot(m), self.eta, self.k) * self.specular_reflectance * g1;
        Some(BsdfSample { wi, pdf, weight, delta: false, null: false, eta: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::checks::{albedo, check_weights, dir, integrate_sphere_fine};
    use crate::bsdf::MicrofacetType::{self, Beckmann, Ggx};
    use crate::testing::chi2::{chi2_cases, chi2_test};

    fn conductor(kind: MicrofacetType, au: f32, av: f32) -> RoughConductor {
        RoughConductor {
            distr: Microfacet { kind, alpha_u: au, alpha_v: av },
            // Gold-ish.
            eta: Spectrum::new(0.18, 0.42, 1.37),
            k: Spectrum::new(3.42, 2.35, 1.77),
            specular_reflectance: Spectrum::ONE,
        }
    }

    fn mirror(kind: MicrofacetType, au: f32, av: f32) -> RoughConductor {
        RoughConductor { eta: Spectrum::ZERO, k: Spectrum::ONE, ..conductor(kind, au, av) }
    }

    fn cases() -> Vec<(RoughConductor, Vec3)> {
        let mut v = Vec::new();
        for kind in [Beckmann, Ggx] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                for c in [0.9f32, 0.4, 0.05] {
                    v.push((conductor(kind, au, av), dir(c, 0.7)));
                }
            }
        }
        v
    }

    #[test]
    fn sampling_matches_pdf() {
        let a = chi2_cases(
            "roughconductor",
            200_000,
            300,
            &cases(),
            |b, wo, u1, u| b.sample(wo, u1, u).map(|s| s.wi),
            |b, wo, wi| b.pdf(wo, wi) as f64,
        );
        // Power: the pdf without G1(wo) (the non-visible D cos density
        // transformed by the same Jacobian) must be rejected.
        let (b, wo) = (conductor(Ggx, 0.5, 0.5), dir(0.3, 0.0));
        let p = chi2_test(
            200_000,
            299,
            |u1, u| b.sample(wo, u1, u).map(|s| s.wi),
            |wi| {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                let m = (wo + wi).normalize();
                (b.distr.eval(m) * m.z / (4.0 * wi.dot(m))) as f64
            },
        );
        println!("roughconductor wrong pdf: p = {p:.3e}");
        assert!(p < a, "wrong pdf accepted: p = {p}");
    }

    #[test]
    fn pdf_integrates_to_sample_probability() {
        for (b, wo) in cases() {
            if b.distr.alpha_u < 0.1 && wo.z < 0.1 {
                // The grazing lobe is a few 1e-3 rad thin: not resolved by
                // the quadrature grid (the chi-square test covers it).
                continue;
            }
            // The probability that sample() returns a direction.
            let n = 100_000;
            let mut rng = crate::testing::TestRng::new(5);
            let hits = (0..n).filter(|_| b.sample(wo, 0.5, rng.next_2d()).is_some()).count();
            let prob = hits as f64 / n as f64;
            let total = integrate_sphere_fine(2000, 400, |wi| b.pdf(wo, wi) as f64);
            let tol = 3.0 * (prob * (1.0 - prob) / n as f64).sqrt() + 3e-3;
            assert!((total - prob).abs() < tol, "{:?} wo={wo}: ∫ pdf = {total}, P(sample) = {prob}", b.distr);
        }
    }

    #[test]
    fn weights_are_eval_cos_over_pdf() {
        for (b, _) in cases() {
            let wos = [dir(0.9, 0.7), dir(0.4, 2.0), dir(0.05, -1.0)];
            let n = check_weights(
                7,
                &wos,
                |wo, u, u2| b.sample(wo, u, u2),
                |wo, wi| b.eval(wo, wi),
                |wo, wi| b.pdf(wo, wi),
            );
            assert!(n > 4000, "{n}");
        }
    }

    #[test]
    fn reciprocal_and_one_sided() {
        let mut rng = crate::testing::TestRng::new(11);
        for (b, _) in cases() {
            for _ in 0..200 {
                let a = dir(rng.next_f32(), 6.3 * rng.next_f32());
                let c = dir(rng.next_f32(), 6.3 * rng.next_f32());
                let (f1, f2) = (b.eval(a, c), b.eval(c, a));
                assert!((f1 - f2).abs().max_element() <= 1e-5 * f1.max_element().max(1.0), "{f1} vs {f2}");
                let below = Vec3::new(c.x, c.y, -c.z);
                assert_eq!(b.eval(a, below), Spectrum::ZERO);
                assert_eq!(b.eval(below, a), Spectrum::ZERO);
                assert_eq!(b.pdf(a, below), 0.0);
            }
            assert!(b.sample(Vec3::new(0.3, 0.0, -0.9).normalize(), 0.5, Vec2::splat(0.5)).is_none());
        }
    }

    /// White furnace with a perfect mirror Fresnel (η = 0, k = 1): the mean
    /// sample weight equals ∫ f cos dω computed by quadrature of eval(),
    /// is ≈ 1 for small α and below 1 (single-scattering loss) otherwise.
    #[test]
    fn white_furnace() {
        for kind in [Beckmann, Ggx] {
            for (au, av) in [(0.02, 0.02), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                let b = mirror(kind, au, av);
                for c in [1.0f32, 0.5, 0.1] {
                    let wo = dir(c, 0.3);
                    let (mean, se) = albedo(200_000, 21, wo, |wo, u, u2| b.sample(wo, u, u2));
                    let quad = integrate_sphere_fine(3000, 600, |wi| (b.eval(wo, wi).x * wi.z.max(0.0)) as f64);
                    println!("furnace {kind:?} {au}/{av} cos {c}: MC {mean:.5} ± {se:.5}, quadrature {quad:.5}");
                    assert!(mean <= 1.0 + 4.0 * se + 1e-6, "albedo {mean} > 1");
                    if au >= 0.1 || c > 0.2 {
                        // The quadrature resolves the lobe (narrow lobes at
                        // grazing angles are left to the Monte Carlo check).
                        assert!((mean - quad).abs() < 4.0 * se + 2e-3, "MC {mean} vs quadrature {quad}");
                    }
                    if au <= 0.02 && c >= 0.5 {
                        assert!(mean > 0.99, "smooth limit: {mean}");
                    }
                }
            }
        }
        // Coloured conductor: every channel's albedo below 1.
        let b = conductor(Ggx, 0.3, 0.3);
        let mut rng = crate::testing::TestRng::new(4);
        let mut sum = Spectrum::ZERO;
        for _ in 0..50_000 {
            if let Some(s) = b.sample(dir(0.6, 0.0), rng.next_f32(), rng.next_2d()) {
                sum += s.weight;
            }
        }
        assert!((sum / 50_000.0).max_element() < 1.0);
    }

    // Generated with Mitsuba 3.9.1 (scalar_rgb), for each case:
    //   b = mi.load_dict(d); si = mi.SurfaceInteraction3f(); si.wi = wo
    //   si.sh_frame = mi.Frame3f([0, 0, 1]); ctx = mi.BSDFContext()
    //   b.eval(ctx, si, wi), b.pdf(ctx, si, wi)
    // with wo = normalize(0.3, 0.2, 0.8), wi_r = normalize(-0.5, 0.1, 0.6),
    // wi_t = normalize(-0.4, -0.3, -0.7), wi_g = normalize(0.9, -0.2, 0.1).
    // Mitsuba's eval includes |cos θ_i|.
    // d = {'type': 'roughconductor', 'distribution': 'ggx', 'alpha_u': 0.2, 'alpha_v': 0.5,
    //      'eta': {'type': 'rgb', 'value': [0.2, 0.9, 1.5]}, 'k': {'type': 'rgb', 'value': [3.0, 2.5, 2.0]}}
    // (and 'alpha': 0.4 for the second case, at wi_g).
    #[test]
    fn matches_mitsuba() {
        let wo = Vec3::new(0.3418817, 0.2279212, 0.9116846);
        let cases = [
            (0.2, 0.5, Vec3::new(-0.6350006, 0.1270001, 0.7620008), [0.2425836, 0.1667896, 0.1092068], 0.2650971),
            (0.4, 0.4, Vec3::new(0.970495, -0.2156655, 0.1078328), [0.01133892, 0.007796488, 0.005113807], 0.02962289),
        ];
        for (au, av, wi, e, p) in cases {
            let b = RoughConductor {
                distr: Microfacet { kind: Ggx, alpha_u: au, alpha_v: av },
                eta: Spectrum::new(0.2, 0.9, 1.5),
                k: Spectrum::new(3.0, 2.5, 2.0),
                specular_reflectance: Spectrum::ONE,
            };
            let ours = b.eval(wo, wi) * wi.z.abs();
            let e = Spectrum::from(e);
            assert!(((ours - e) / e).abs().max_element() < 1e-3, "{ours} vs Mitsuba {e}");
            assert!((b.pdf(wo, wi) / p - 1.0).abs() < 1e-3, "{} vs Mitsuba {p}", b.pdf(wo, wi));
        }
    }
}
