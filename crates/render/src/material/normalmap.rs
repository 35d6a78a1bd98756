//! Mitsuba `normalmap`: the shading frame from a tangent-space normal map.

use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum};
use glam::Vec3;

/// Mitsuba 3.9.1's `flip_invalid_normals` (default true): a perturbed normal
/// `n` (relative to the unperturbed shading frame) that faces away from the
/// incident direction is mirrored about the unperturbed normal's axis.
#[inline]
pub(crate) fn flip_invalid(si: &SurfaceInteraction, n: Vec3) -> Vec3 {
    let wi = si.to_local(si.wo);
    if wi.z * wi.dot(n) <= 0.0 {
        Vec3::new(-n.x, -n.y, n.z)
    } else {
        n
    }
}

/// The perturbed normal relative to `si.sh_frame` for a normal-map texel
/// `rgb` (in [0, 1]³), and the frame it spans there (Mitsuba 3.9.1's
/// `NormalMap::frame`, first half).
pub fn relative_frame(si: &SurfaceInteraction, rgb: Spectrum) -> Frame {
    let n = flip_invalid(si, rgb * 2.0 - 1.0);
    let n = n.normalize();
    let s = (Vec3::X - n * n.x).normalize();
    Frame { s, t: n.cross(s), n }
}

/// The perturbed world-space shading frame for a normal-map texel `rgb`:
/// n = 2·rgb − 1 in the unperturbed shading frame (flipped if invalid, see
/// `flip_invalid`), s = the local x axis made orthogonal to n, t = n × s.
/// Falls back to the unperturbed frame for a zero normal.
pub fn perturbed_frame(si: &SurfaceInteraction, rgb: Spectrum) -> Frame {
    let f = relative_frame(si, rgb);
    if !(f.n.is_finite() && f.s.is_finite()) {
        return si.sh_frame;
    }
    Frame { s: si.to_world(f.s), t: si.to_world(f.t), n: si.to_world(f.n) }
}

/// Mitsuba 3.9.1's `eval_shadow_terminator` (Estevez et al. 2019), on by
/// default (`use_shadowing_function`): `n_rel` is the perturbed normal and
/// `w` a direction, both relative to the unperturbed shading frame.
#[inline]
pub fn shadow_terminator(n_rel: Vec3, w: Vec3) -> f32 {
    let tan2 = |v: Vec3| {
        let c2 = v.z * v.z;
        (1.0 - c2).max(0.0) / c2
    };
    let alpha2 = (0.125 * tan2(n_rel)).min(1.0);
    2.0 / (1.0 + (1.0 + alpha2 * tan2(w)).sqrt())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use glam::Vec2;

    /// The hit used by the normal- and bump-map tests (see the Python below).
    pub(crate) fn test_si(wo: Vec3) -> SurfaceInteraction {
        let n = Vec3::new(0.2, 0.3, 0.9).normalize();
        let dpdu = Vec3::new(1.0, 0.1, -0.3);
        SurfaceInteraction {
            p: Vec3::ZERO,
            t: 1.0,
            n,
            sh_frame: SurfaceInteraction::frame_from_dpdu(n, dpdu),
            uv: Vec2::new(0.3, 0.6),
            dpdu,
            dpdv: n.cross(dpdu),
            shape: 0,
            prim: 0,
            bary: glam::Vec2::ZERO,
            wo: wo.normalize(),
        }
    }

    /// A diffuse (reflectance 0.5) BSDF's value under a perturbed frame as
    /// Mitsuba's wrappers compute it: the nested value in the perturbed
    /// frame, zero if `wi` changes side, times the shadowing term.
    pub(crate) fn wrapped_diffuse(si: &SurfaceInteraction, rel: Frame, wi: Vec3, shadowing: bool) -> f32 {
        let world = Frame { s: si.to_world(rel.s), t: si.to_world(rel.t), n: si.to_world(rel.n) };
        let (cos_orig, cos_pert) = (si.to_local(wi).z, world.to_local(wi).z);
        if !(cos_orig * cos_pert > 0.0) || cos_pert <= 0.0 {
            return 0.0;
        }
        let g = if shadowing { shadow_terminator(rel.n, si.to_local(wi)) } else { 1.0 };
        0.5 / std::f32::consts::PI * cos_pert * g
    }

    // Mitsuba 3.9.1 (scalar_rgb), a 2x2 EXR of rgb (0.7, 0.4, 0.9):
    //   b = mi.load_dict({'type': 'normalmap', 'normalmap': {'type': 'bitmap',
    //        'filename': 'n.exr', 'raw': True}, 'bsdf': {'type': 'diffuse'}})
    //   si.n = normalize([0.2, 0.3, 0.9]); si.dp_du = [1, 0.1, -0.3]; si.sh_frame = Frame3f(si.n)
    //   si.initialize_sh_frame(); si.wi = si.to_local(normalize(w)); si.uv = [0.3, 0.6]
    //   b.eval(mi.BSDFContext(), si, si.to_local(normalize([-0.3, 0.5, 1.0])))
    //   (and with 'use_shadowing_function': False)
    #[test]
    fn normal_map_frame_matches_mitsuba() {
        let si = test_si(Vec3::new(0.1, 0.2, 1.0));
        assert!((si.sh_frame.s - Vec3::new(0.96232194, 0.1076014, -0.24971648)).length() < 1e-5);
        let wi = Vec3::new(-0.3, 0.5, 1.0).normalize();
        for w in [Vec3::new(0.1, 0.2, 1.0), Vec3::new(0.9, -0.8, 0.1)] {
            let si = test_si(w);
            let rel = relative_frame(&si, Vec3::new(0.7, 0.4, 0.9));
            let f = perturbed_frame(&si, Vec3::new(0.7, 0.4, 0.9));
            assert!((f.n - si.to_world(rel.n)).length() < 1e-6);
            assert!(f.s.dot(f.n).abs() < 1e-6 && (f.s.cross(f.t) - f.n).length() < 1e-5);
            assert!((wrapped_diffuse(&si, rel, wi, false) - 0.0859639123082161).abs() < 1e-6);
            assert!((wrapped_diffuse(&si, rel, wi, true) - 0.0857258290052414).abs() < 1e-6);
        }
    }

    /// The whole path through `Material::bsdf`: the perturbed frame, the
    /// side check and the shadow terminator give Mitsuba's value
    /// (eval · cos θ, as Mitsuba's `eval` includes the cosine).
    #[test]
    fn normal_map_material_matches_mitsuba_eval() {
        use crate::material::Material;
        use crate::texture::{Bitmap, FilterType, Texture, WrapMode};
        let tex = Bitmap::new(
            2,
            2,
            vec![Vec3::new(0.7, 0.4, 0.9); 4],
            FilterType::Bilinear,
            WrapMode::Repeat,
            glam::Affine2::IDENTITY,
        )
        .unwrap();
        let m = Material::NormalMap {
            normals: Texture::Bitmap(std::sync::Arc::new(tex)),
            inner: Box::new(Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Vec3::splat(0.5).into() })),
        };
        let wi = Vec3::new(-0.3, 0.5, 1.0).normalize();
        for w in [Vec3::new(0.1, 0.2, 1.0), Vec3::new(0.9, -0.8, 0.1)] {
            let mut si = test_si(w);
            let scratch = crate::material::Scratch::new();
            let bsdf = m.bsdf(&mut si, &scratch);
            let (wo_l, wi_l) = (si.to_local(si.wo), si.to_local(wi));
            let v = bsdf.eval(wo_l, wi_l).x * wi_l.z;
            assert!((v - 0.0857258290052414).abs() < 1e-6, "{v}");
            // A direction below the unperturbed surface but above the perturbed one gets nothing.
            let below = (si.sh_frame.n - 1.02 * test_si(w).sh_frame.n).normalize();
            let b_l = si.to_local(below);
            if b_l.z > 0.0 {
                assert_eq!(bsdf.eval(wo_l, b_l).x, 0.0);
                assert_eq!(bsdf.pdf(wo_l, b_l), 0.0);
            }
        }
    }
}
