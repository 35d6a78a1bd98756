//! Mitsuba `blendbsdf`: (1 − weight) · first + weight · second, with
//! Mitsuba 3.9.1's sampling (src/bsdfs/blendbsdf.cpp): `u` picks the second
//! BSDF when u ≤ weight, the chosen one samples a direction, and the sample
//! carries the mixture's pdf, w₀·p₀ + w₁·p₁, and the mixture's value over it:
//! (w₀·f₀·cos + w₁·f₁·cos) / pdf. For a delta sample Mitsuba mixes the
//! lobe's discrete probability with the other BSDF's density in the same
//! way; Penumbra does exactly the same, to render the same image.
//!
//! The per-hit value holds references to the two nested materials and a copy
//! of the hit: each evaluation resolves the nested materials there (they may
//! be wrappers with their own shading frames: `twosided`, `normalmap`, ...),
//! so no allocation happens per sample. Directions are mapped between the
//! blend's shading frame and each nested one's, and cosines are taken in the
//! nested frame, as Mitsuba's nested BSDFs do.

use super::Material;
use crate::bsdf::{Bsdf, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Copy)]
pub struct Blend<'a> {
    /// The second BSDF's weight, clamped to [0, 1].
    pub weight: f32,
    pub first: &'a Material,
    pub second: &'a Material,
    /// The hit, with the shading frame the blend is evaluated in.
    pub si: SurfaceInteraction,
}

/// A nested BSDF and the map from the blend's local frame to its own.
struct Nested<'a> {
    bsdf: Bsdf<'a>,
    /// Rows of the change of basis (None when the frames agree).
    map: Option<[Vec3; 3]>,
}

impl Nested<'_> {
    #[inline]
    fn to_nested(&self, w: Vec3) -> Vec3 {
        match self.map {
            None => w,
            Some(m) => Vec3::new(m[0].dot(w), m[1].dot(w), m[2].dot(w)),
        }
    }

    #[inline]
    fn from_nested(&self, w: Vec3) -> Vec3 {
        match self.map {
            None => w,
            Some(m) => m[0] * w.x + m[1] * w.y + m[2] * w.z,
        }
    }

    /// f · |cos θ_i| in the nested frame, and the pdf, for blend-local directions.
    #[inline]
    fn eval_cos_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let (wo, wi) = (self.to_nested(wo), self.to_nested(wi));
        (self.bsdf.eval(wo, wi) * wi.z.abs(), self.bsdf.pdf(wo, wi))
    }
}

impl<'a> Blend<'a> {
    fn nested(&self, m: &'a Material) -> Nested<'a> {
        let mut si = self.si;
        let bsdf = m.bsdf(&mut si);
        let (a, b) = (self.si.sh_frame, si.sh_frame);
        let map = if a.s == b.s && a.t == b.t && a.n == b.n {
            None
        } else {
            // Row k: nested axis k in blend-local coordinates.
            Some([a.to_local(b.s), a.to_local(b.t), a.to_local(b.n)])
        };
        Nested { bsdf, map }
    }

    /// Whether either nested BSDF has a non-delta lobe.
    pub fn has_smooth(&self) -> bool {
        (self.weight < 1.0 && self.nested(self.first).bsdf.has_smooth())
            || (self.weight > 0.0 && self.nested(self.second).bsdf.has_smooth())
    }

    /// f · |cos θ_i| of the mixture (cosines in each nested frame) and its pdf.
    fn eval_cos_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let w = self.weight;
        let mut f = Spectrum::ZERO;
        let mut p = 0.0;
        if w < 1.0 {
            let (f0, p0) = self.nested(self.first).eval_cos_pdf(wo, wi);
            f += f0 * (1.0 - w);
            p += p0 * (1.0 - w);
        }
        if w > 0.0 {
            let (f1, p1) = self.nested(self.second).eval_cos_pdf(wo, wi);
            f += f1 * w;
            p += p1 * w;
        }
        (f, p)
    }

    /// f without the cosine of the blend's frame (Penumbra's contract).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wi.z == 0.0 {
            return Spectrum::ZERO;
        }
        self.eval_cos_pdf(wo, wi).0 / wi.z.abs()
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_cos_pdf(wo, wi).1
    }

    pub fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let w = self.weight;
        // Mitsuba: the second BSDF when u ≤ weight, its number rescaled.
        let (chosen, other, w_chosen, u) = if u > w {
            (self.first, self.second, 1.0 - w, (u - w) / (1.0 - w))
        } else {
            (self.second, self.first, w, if w > 0.0 { u / w } else { 0.0 })
        };
        let n = self.nested(chosen);
        let s = n.bsdf.sample(n.to_nested(wo), u.min(ONE_MINUS_EPS), u2)?;
        let wi = n.from_nested(s.wi);
        let w_other = 1.0 - w_chosen;
        let (f_other, p_other) =
            if w_other > 0.0 { self.nested(other).eval_cos_pdf(wo, wi) } else { (Spectrum::ZERO, 0.0) };
        let pdf = w_chosen * s.pdf + w_other * p_other;
        if !(pdf > 0.0) {
            return None;
        }
        let weight = (s.weight * (w_chosen * s.pdf) + f_other * w_other) / pdf;
        Some(BsdfSample { wi, pdf, weight, delta: s.delta, eta: s.eta })
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::MicrofacetType;
    use crate::material::Roughness;
    use crate::math::Frame;
    use crate::testing::chi2::{alpha, chi2_test};
    use crate::testing::TestRng;
    use crate::texture::Texture;

    fn diffuse() -> Material {
        Material::Diffuse { reflectance: Vec3::splat(0.5).into() }
    }

    fn rough_mirror(alpha: f32) -> Material {
        Material::RoughConductor {
            roughness: Roughness {
                kind: MicrofacetType::Ggx,
                alpha_u: Texture::Constant(Vec3::splat(alpha)),
                alpha_v: Texture::Constant(Vec3::splat(alpha)),
            },
            eta: Texture::Constant(Vec3::ZERO),
            k: Texture::Constant(Vec3::ONE),
            specular_reflectance: Texture::Constant(Vec3::ONE),
        }
    }

    fn mirror() -> Material {
        Material::Conductor {
            eta: Texture::Constant(Vec3::ZERO),
            k: Texture::Constant(Vec3::ONE),
            specular_reflectance: Texture::Constant(Vec3::ONE),
        }
    }

    /// A hit whose shading frame is the world frame (local = world).
    fn si() -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            t: 1.0,
            n: Vec3::Z,
            sh_frame: Frame { s: Vec3::X, t: Vec3::Y, n: Vec3::Z },
            uv: Vec2::ZERO,
            dpdu: Vec3::X,
            dpdv: Vec3::Y,
            shape: 0,
            prim: 0,
            bary: Vec2::ZERO,
            wo: Vec3::Z,
        }
    }

    fn blend<'a>(w: f32, a: &'a Material, b: &'a Material) -> Blend<'a> {
        Blend { weight: w, first: a, second: b, si: si() }
    }

    fn dir(c: f32, phi: f32) -> Vec3 {
        let s = (1.0 - c * c).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), c)
    }

    /// Values printed by Mitsuba 3.9.1 (scalar_rgb):
    /// ```python
    /// diff = {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': [0.5] * 3}}
    /// rc = {'type': 'roughconductor', 'distribution': 'ggx', 'alpha': 0.3}; cond = {'type': 'conductor'}
    /// b = mi.load_dict({'type': 'blendbsdf', 'weight': 0.3, 'a': diff, 'b': rc})   # and weight 0.4, diff + cond
    /// si = mi.SurfaceInteraction3f(); si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1)); si.wi = wo
    /// b.eval(ctx, si, wi)[0], b.pdf(ctx, si, wi); bs, w = b.sample(ctx, si, u1, mi.Point2f(*u2))
    /// ```
    /// with wo, wi = dir(cos, phi) as below (Mitsuba's eval includes the cosine).
    #[test]
    fn eval_pdf_and_samples_match_mitsuba() {
        let pi = std::f32::consts::PI;
        let (d, rc, cond) = (diffuse(), rough_mirror(0.3), mirror());
        let pairs =
            [(dir(0.8, 0.3), dir(0.7, 0.3 + pi)), (dir(0.5, 1.0), dir(0.9, 2.5)), (dir(0.3, 0.0), dir(0.2, 3.0))];
        let evals: [(&Blend, [(f32, f32); 3]); 2] = [
            (&blend(0.3, &d, &rc), [(0.36388212, 0.4484134), (0.125889, 0.22629112), (0.20144913, 0.2933946)]),
            (&blend(0.4, &d, &cond), [(0.06684507, 0.13369015), (0.08594367, 0.17188734), (0.01909859, 0.03819719)]),
        ];
        for (b, want) in evals {
            for ((wo, wi), (f, p)) in pairs.iter().zip(want) {
                let got_f = b.eval(*wo, *wi).x * wi.z;
                let got_p = b.pdf(*wo, *wi);
                assert!((got_f - f).abs() < 1e-3 * f.max(1.0), "eval {got_f} vs {f}");
                assert!((got_p - p).abs() < 1e-3 * p.max(1.0), "pdf {got_p} vs {p}");
            }
        }
        // (wo, u1, u2) -> (wi, pdf, weight). With the mirror, u1 ≤ 0.4 picks
        // it: Mitsuba mixes its discrete probability 1 with the diffuse
        // density (weight 0.8618, not 1), and so does Penumbra.
        let samples: [(&Blend, [(Vec3, f32, Vec2, Vec3, f32, f32); 4]); 2] = [
            (
                &blend(0.3, &d, &rc),
                [
                    (
                        pairs[0].0,
                        0.1,
                        Vec2::new(0.3, 0.6),
                        Vec3::new(-0.60865307, 0.01092176, 0.79336101),
                        0.42698407,
                        0.78543305,
                    ),
                    (
                        pairs[0].0,
                        0.7,
                        Vec2::new(0.3, 0.6),
                        Vec3::new(-0.36955175, 0.15307342, 0.91651517),
                        0.35137314,
                        0.70762461,
                    ),
                    (
                        pairs[1].0,
                        0.2,
                        Vec2::new(0.8, 0.1),
                        Vec3::new(0.50146705, -0.18980624, 0.84409964),
                        0.20729004,
                        0.54551053,
                    ),
                    (
                        pairs[1].0,
                        0.9,
                        Vec2::new(0.2, 0.9),
                        Vec3::new(-0.44445628, 0.66517562, 0.60000002),
                        0.1432294,
                        0.53083056,
                    ),
                ],
            ),
            (
                &blend(0.4, &d, &cond),
                [
                    (
                        pairs[0].0,
                        0.1,
                        Vec2::new(0.3, 0.6),
                        Vec3::new(-0.57320189, -0.17731212, 0.8),
                        0.55278873,
                        0.86180186,
                    ),
                    (
                        pairs[0].0,
                        0.7,
                        Vec2::new(0.3, 0.6),
                        Vec3::new(-0.36955175, 0.15307342, 0.91651517),
                        0.1750415,
                        0.5,
                    ),
                    (
                        pairs[1].0,
                        0.2,
                        Vec2::new(0.8, 0.1),
                        Vec3::new(-0.46791553, -0.72873527, 0.5),
                        0.49549296,
                        0.90363842,
                    ),
                    (
                        pairs[1].0,
                        0.9,
                        Vec2::new(0.2, 0.9),
                        Vec3::new(-0.44445628, 0.66517562, 0.60000002),
                        0.11459156,
                        0.5,
                    ),
                ],
            ),
        ];
        for (b, cases) in samples {
            for (wo, u1, u2, wi, pdf, weight) in cases {
                let s = b.sample(wo, u1, u2).unwrap();
                assert!((s.wi - wi).abs().max_element() < 1e-4, "wi {} vs {wi}", s.wi);
                assert!((s.pdf - pdf).abs() < 1e-3 * pdf, "pdf {} vs {pdf}", s.pdf);
                assert!((s.weight.x - weight).abs() < 1e-3 * weight, "weight {} vs {weight}", s.weight.x);
            }
        }
    }

    #[test]
    fn sampling_matches_pdf_and_weights_are_f_cos_over_pdf() {
        let (d, rc, rc2) = (diffuse(), rough_mirror(0.3), rough_mirror(0.05));
        let blends = [blend(0.3, &d, &rc), blend(0.8, &d, &rc2), blend(0.5, &rc, &rc2), blend(1.0, &d, &rc)];
        let wos = [dir(0.9, 0.4), dir(0.4, 2.0), dir(0.1, -1.0)];
        let a = alpha(blends.len() * wos.len() + 1);
        let mut rng = TestRng::new(3);
        for (i, b) in blends.iter().enumerate() {
            for (j, &wo) in wos.iter().enumerate() {
                let p = chi2_test(
                    200_000,
                    900 + (i * 3 + j) as u64,
                    |u1, u| b.sample(wo, u1, u).map(|s| s.wi),
                    |wi| b.pdf(wo, wi) as f64,
                );
                assert!(p > a, "blend {i} wo={wo}: p = {p}");
                for _ in 0..500 {
                    let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) else { continue };
                    assert!(!s.delta && (s.pdf - b.pdf(wo, s.wi)).abs() <= 1e-3 * s.pdf);
                    let expect = b.eval(wo, s.wi) * s.wi.z.abs() / s.pdf;
                    assert!((s.weight - expect).abs().max_element() <= 1e-3 * expect.max_element().max(1e-2));
                }
            }
        }
        // Power: the pdf of the first BSDF alone must fail.
        let b = &blends[0];
        let wrong = b.nested(b.first).bsdf;
        let p =
            chi2_test(200_000, 899, |u1, u| b.sample(wos[0], u1, u).map(|s| s.wi), |wi| wrong.pdf(wos[0], wi) as f64);
        assert!(p < a, "wrong pdf accepted: p = {p}");
    }

    /// A nested wrapper with its own frame (twosided seen from below): the
    /// blend maps directions into it and takes cosines there.
    #[test]
    fn nested_frames_are_respected() {
        let rc = rough_mirror(0.3);
        let two = Material::TwoSided(Box::new(diffuse()), Box::new(diffuse()));
        let b = blend(0.5, &two, &rc);
        // Seen from below: the twosided diffuse still reflects on the lower
        // side, the one-sided conductor is black there.
        let mut s = si();
        s.wo = -dir(0.7, 0.2);
        let b = Blend { si: s, ..b };
        let (wo, wi) = (-dir(0.7, 0.2), -dir(0.5, 2.0));
        let f = b.eval(wo, wi);
        assert!((f.x - 0.5 * 0.5 / std::f32::consts::PI).abs() < 1e-5, "{f}");
        assert!((b.pdf(wo, wi) - 0.5 * 0.5 / std::f32::consts::PI).abs() < 1e-5);
    }
}
