//! Tests of `blendbsdf` as the scene stores it: a [`super::Material::Blend`]
//! resolved at a hit into the per-hit [`crate::bsdf::Blend`] (whose code is
//! in `bsdf/blend.rs`), checked against values printed by Mitsuba 3.9.1,
//! the chi-square test of its sampling, and nested shading frames.

#[cfg(test)]
mod tests {
    use crate::bsdf::{
        Blend, BsdfKind, BsdfModel, ConductorParams, DiffuseParams, MicrofacetType, RoughConductorParams, Roughness,
    };
    use crate::geometry::SurfaceInteraction;
    use crate::material::{Material, Scratch};
    use crate::math::Frame;
    use crate::testing::chi2::{alpha, chi2_test};
    use crate::testing::TestRng;
    use crate::texture::Texture;
    use glam::{Vec2, Vec3};

    fn diffuse() -> Material {
        Material::Diffuse(DiffuseParams { reflectance: Vec3::splat(0.5).into() })
    }

    fn rough_mirror(alpha: f32) -> Material {
        Material::RoughConductor(RoughConductorParams {
            roughness: Roughness {
                kind: MicrofacetType::Ggx,
                alpha_u: Texture::Constant(Vec3::splat(alpha)),
                alpha_v: Texture::Constant(Vec3::splat(alpha)),
            },
            eta: Texture::Constant(Vec3::ZERO),
            k: Texture::Constant(Vec3::ONE),
            specular_reflectance: Texture::Constant(Vec3::ONE),
        })
    }

    fn mirror() -> Material {
        Material::Conductor(ConductorParams {
            eta: Texture::Constant(Vec3::ZERO),
            k: Texture::Constant(Vec3::ONE),
            specular_reflectance: Texture::Constant(Vec3::ONE),
        })
    }

    /// A hit whose shading frame is the world frame (local = world).
    fn si() -> SurfaceInteraction {
        SurfaceInteraction {
            t: 1.0,
            sh_frame: Frame { s: Vec3::X, t: Vec3::Y, n: Vec3::Z },
            ..SurfaceInteraction::at_uv(Vec2::ZERO)
        }
    }

    /// The blend of `a` and `b` with weight `w`, resolved at `si`.
    fn blend_at<'a>(w: f32, a: &Material, b: &Material, si: SurfaceInteraction, scratch: &'a Scratch) -> Blend<'a> {
        let m = Material::Blend {
            weight: Texture::Constant(Vec3::splat(w)),
            first: Box::new(a.clone()),
            second: Box::new(b.clone()),
        };
        // The material only lives here: leak it (tests only) so the
        // resolved blend may outlive this call.
        let m: &'a Material = Box::leak(Box::new(m));
        let mut si = si;
        match m.bsdf(&mut si, scratch).kind {
            BsdfKind::Blend(b) => b,
            k => panic!("not a blend: {k:?}"),
        }
    }

    fn blend<'a>(w: f32, a: &Material, b: &Material, scratch: &'a Scratch) -> Blend<'a> {
        blend_at(w, a, b, si(), scratch)
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
        let scratch = Scratch::new();
        let pairs =
            [(dir(0.8, 0.3), dir(0.7, 0.3 + pi)), (dir(0.5, 1.0), dir(0.9, 2.5)), (dir(0.3, 0.0), dir(0.2, 3.0))];
        let evals: [(&Blend, [(f32, f32); 3]); 2] = [
            (
                &blend(0.3, &d, &rc, &scratch),
                [(0.36388212, 0.4484134), (0.125889, 0.22629112), (0.20144913, 0.2933946)],
            ),
            (
                &blend(0.4, &d, &cond, &scratch),
                [(0.06684507, 0.13369015), (0.08594367, 0.17188734), (0.01909859, 0.03819719)],
            ),
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
                &blend(0.3, &d, &rc, &scratch),
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
                &blend(0.4, &d, &cond, &scratch),
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
        let scratch = Scratch::new();
        let blends = [
            blend(0.3, &d, &rc, &scratch),
            blend(0.8, &d, &rc2, &scratch),
            blend(0.5, &rc, &rc2, &scratch),
            blend(1.0, &d, &rc, &scratch),
        ];
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
        let wrong = b.first.bsdf;
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
        // Seen from below: the twosided diffuse still reflects on the lower
        // side, the one-sided conductor is black there.
        let mut s = si();
        s.wo = -dir(0.7, 0.2);
        let scratch = Scratch::new();
        let b = blend_at(0.5, &two, &rc, s, &scratch);
        let (wo, wi) = (-dir(0.7, 0.2), -dir(0.5, 2.0));
        let f = b.eval(wo, wi);
        assert!((f.x - 0.5 * 0.5 / std::f32::consts::PI).abs() < 1e-5, "{f}");
        assert!((b.pdf(wo, wi) - 0.5 * 0.5 / std::f32::consts::PI).abs() < 1e-5);
    }
}
