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

/// Mitsuba `plastic` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct Plastic {
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    /// Reflectance ρ of the diffuse base (linear RGB).
    pub diffuse_reflectance: Spectrum,
    /// Tint of the specular reflection.
    pub specular_reflectance: Spectrum,
    /// Mitsuba's `nonlinear`: account for colour shifts from internal scattering.
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
    /// Reflectance ρ of the diffuse base.
    pub diffuse_reflectance: Texture,
    /// Tint of the specular reflection.
    pub specular_reflectance: Texture,
    /// Mitsuba's `nonlinear`: account for colour shifts from internal scattering.
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
    pub fn diffuse(&self) -> Spectrum {
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
                null: false,
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
        Some(BsdfSample { wi, pdf, weight, delta: false, null: false, eta: 1.0 })
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

    /// Smooth `plastic` against Mitsuba 3.9.1 (scalar_rgb). Printed by:
    ///
    /// ```python
    /// import drjit as dr, mitsuba as mi
    /// mi.set_variant('scalar_rgb')
    /// n = lambda *v: dr.normalize(mi.Vector3f(*v))
    /// wo, wi_r = n(0.3, 0.2, 0.8), n(-0.5, 0.1, 0.6)
    /// wi_t, wi_g = n(-0.4, -0.3, -0.7), n(0.9, -0.2, 0.1)
    /// rgb = lambda *c: {'type': 'rgb', 'value': list(c)}
    /// cases = [  # (bsdf, si.wi, wo)
    ///     ({'type': 'plastic', 'int_ior': 1.49, 'diffuse_reflectance': rgb(0.5, 0.3, 0.8)}, wo, wi_r),
    ///     ({'type': 'plastic', 'int_ior': 1.7, 'ext_ior': 1.1, 'nonlinear': True,
    ///       'diffuse_reflectance': rgb(0.9, 0.6, 0.2), 'specular_reflectance': rgb(0.8, 0.7, 0.9)}, wi_g, wo),
    ///     ({'type': 'plastic', 'int_ior': 1.33, 'diffuse_reflectance': rgb(0.2, 0.7, 0.4)}, wo, wi_g),
    ///     (case 0's bsdf, wo, wi_t), (case 0's bsdf, wi_t, wo)]
    /// ctx = mi.BSDFContext()
    /// for d, a, b in cases:
    ///     bsdf = mi.load_dict(d)
    ///     si = mi.SurfaceInteraction3f(); si.wi = a; si.sh_frame = mi.Frame3f([0, 0, 1])
    ///     print(bsdf.eval(ctx, si, b), bsdf.pdf(ctx, si, b))
    ///     bs, w = bsdf.sample(ctx, si, 0.0, [0.3, 0.6])    # the specular lobe
    ///     print(bs.wo, bs.pdf, w)
    ///     bs, w = bsdf.sample(ctx, si, 0.999, [0.3, 0.6])  # the diffuse lobe
    ///     print(bs.wo, bs.pdf, w)
    /// ```
    ///
    /// Mitsuba's eval includes cos θ_i; its η is int_ior / ext_ior (ext_ior
    /// defaults to "air", 1.000277, so case 0 has η = 1.48959) and its
    /// specular sampling weight s_mean / (d_mean + s_mean) of the channel
    /// means. Both sides compute the same closed forms in f32, so they agree
    /// to rounding (relative 1e-4).
    #[test]
    fn matches_mitsuba() {
        let wo = Vec3::new(0.341882, 0.227921, 0.911685);
        let wi_r = Vec3::new(-0.635001, 0.127, 0.762001);
        let wi_g = Vec3::new(0.970495, -0.215666, 0.107833);
        let wi_t = Vec3::new(-0.464991, -0.348743, -0.813733);
        let make = |int_ior: f32, ext_ior: f32, nonlinear: bool, d: [f32; 3], s: [f32; 3]| {
            let eta = int_ior / ext_ior;
            let (d, s) = (Spectrum::from(d), Spectrum::from(s));
            let (d_mean, s_mean) = ((d.x + d.y + d.z) / 3.0, (s.x + s.y + s.z) / 3.0);
            Plastic {
                eta,
                diffuse_reflectance: d,
                specular_reflectance: s,
                nonlinear,
                fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
                specular_sampling_weight: s_mean / (d_mean + s_mean),
            }
        };
        // Mitsuba's default ext_ior, "air".
        let air = crate::bsdf::presets::named_ior("air").unwrap();
        let a = make(1.49, air, false, [0.5, 0.3, 0.8], [1.0; 3]);
        let b = make(1.7, 1.1, true, [0.9, 0.6, 0.2], [0.8, 0.7, 0.9]);
        let c = make(1.33, air, false, [0.2, 0.7, 0.4], [1.0; 3]);
        type Lobe = (f32, [f32; 3]); // (pdf, weight); direction checked separately
        let cases: [(Plastic, Vec3, Vec3, [f32; 3], f32, Option<(Lobe, Lobe)>); 5] = [
            (
                a,
                wo,
                wi_r,
                [0.1225079894065857, 0.07350479811429977, 0.19601278007030487],
                0.2252875566482544,
                Some((
                    (0.0711798146367073, [0.5516578555107117; 3]),
                    (0.2709701359272003, [0.5468478798866272, 0.3281087577342987, 0.8749566674232483]),
                )),
            ),
            (
                b,
                wi_g,
                wo,
                [0.10598835349082947, 0.04957640916109085, 0.011822259053587914],
                0.10557708889245987,
                Some((
                    (0.6361897587776184, [0.6957706809043884, 0.6087992787361145, 0.7827419638633728]),
                    (0.10613647848367691, [1.0039727687835693, 0.46961164474487305, 0.11198613792657852]),
                )),
            ),
            (
                c,
                wo,
                wi_g,
                [0.003502377774566412, 0.012258321046829224, 0.007004755549132824],
                0.032747913151979446,
                Some((
                    (0.04592451453208923, [0.4449117183685303; 3]),
                    (0.2783379852771759, [0.2155425101518631, 0.7543987035751343, 0.4310850203037262]),
                )),
            ),
            // wi below the surface: black, pdf 0.
            (a, wo, wi_t, [0.0; 3], 0.0, None),
            // Seen from below: black, and no sample (Mitsuba: pdf 0, weight 0).
            (a, wi_t, wo, [0.0; 3], 0.0, None),
        ];
        // Mitsuba's diffuse sample for u2 = (0.3, 0.6).
        let wi_diffuse = Vec3::new(-0.36955174803733826, 0.15307341516017914, 0.9165151715278625);
        let close = |x: f32, y: f32| (x - y).abs() <= 1e-4 * y.abs() + 1e-7;
        let close3 = |x: Spectrum, y: [f32; 3]| (0..3).all(|k| close(x[k], y[k]));
        for (k, (m, x, y, e, p, samples)) in cases.into_iter().enumerate() {
            let ours = m.eval(x, y) * y.z.max(0.0);
            assert!(close3(ours, e), "case {k}: eval·cos {ours} vs Mitsuba {e:?}");
            assert!(close(m.pdf(x, y), p), "case {k}: pdf {} vs Mitsuba {p}", m.pdf(x, y));
            let u2 = Vec2::new(0.3, 0.6);
            match samples {
                None => {
                    if x.z <= 0.0 {
                        assert!(m.sample(x, 0.0, u2).is_none() && m.sample(x, 0.999, u2).is_none(), "case {k}");
                    }
                }
                Some(((ps, ws), (pd, wd))) => {
                    let s = m.sample(x, 0.0, u2).expect("specular sample");
                    assert!(s.delta && (s.wi - reflect(x)).abs().max_element() < 1e-6, "case {k}: {s:?}");
                    assert!(
                        close(s.pdf, ps) && close3(s.weight, ws),
                        "case {k}: specular {s:?} vs Mitsuba {ps} {ws:?}"
                    );
                    let s = m.sample(x, 0.999, u2).expect("diffuse sample");
                    assert!(!s.delta && (s.wi - wi_diffuse).abs().max_element() < 1e-5, "case {k}: {s:?}");
                    assert!(close(s.pdf, pd) && close3(s.weight, wd), "case {k}: diffuse {s:?} vs Mitsuba {pd} {wd:?}");
                }
            }
        }
    }
}
