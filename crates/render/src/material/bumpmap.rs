//! Mitsuba `bumpmap`: the shading frame from a height texture's gradient.

use super::normalmap::flip_invalid;
use crate::geometry::SurfaceInteraction;
use crate::math::Frame;
use crate::texture::Texture;

/// The perturbed frame relative to `si.sh_frame` (Mitsuba 3.9.1's
/// `BumpMap::frame`), or `None` where the perturbed tangents are degenerate.
pub fn relative_frame(si: &SurfaceInteraction, height: &Texture, scale: f32) -> Option<Frame> {
    let grad = scale * height.eval_1_grad(si).1;
    let ns = si.sh_frame.n;
    let dp_du = si.dpdu + ns * (grad.x - ns.dot(si.dpdu));
    let dp_dv = si.dpdv + ns * (grad.y - ns.dot(si.dpdv));
    let mut n = dp_du.cross(dp_dv).normalize();
    // Keep the bumped normal on the geometric normal's side.
    if si.n.dot(n) < 0.0 {
        n = -n;
    }
    let n = flip_invalid(si, si.to_local(n));
    // Mitsuba orthogonalises the world-space dp/du against the *local*
    // normal here; reproduced as is (it only sets the rotation about n,
    // which anisotropic BSDFs see).
    let s = (si.dpdu - n * n.dot(si.dpdu)).normalize();
    let f = Frame { s, t: n.cross(s), n };
    (f.n.is_finite() && f.s.is_finite()).then_some(f)
}

/// The perturbed world-space shading frame for the height field
/// `scale · height(uv)`: the normal of the surface displaced along the
/// shading normal, expressed in and re-attached to `si.sh_frame`.
pub fn perturbed_frame(si: &SurfaceInteraction, height: &Texture, scale: f32) -> Frame {
    match relative_frame(si, height, scale) {
        Some(f) => Frame { s: si.to_world(f.s), t: si.to_world(f.t), n: si.to_world(f.n) },
        None => si.sh_frame,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::normalmap::tests::{test_si, wrapped_diffuse};
    use crate::texture::{Bitmap, FilterType, WrapMode};
    use glam::{Affine2, Vec3};
    use std::sync::Arc;

    // Mitsuba 3.9.1 (scalar_rgb), with a 4x2 one-channel EXR of heights
    // [[0.1, 0.5, 0.2, 0.9], [0.3, 0.0, 0.6, 0.4]] and the hit of the
    // normal-map test:
    //   b = mi.load_dict({'type': 'bumpmap', 'texture': {'type': 'bitmap', 'filename': 'h.exr',
    //        'raw': True}, 'scale': 0.5, 'bsdf': {'type': 'diffuse'}})
    //   b.eval(mi.BSDFContext(), si, si.to_local(normalize([-0.3, 0.5, 1.0])))
    //   (and with 'use_shadowing_function': False)
    #[test]
    fn bump_map_frame_matches_mitsuba() {
        let h = [0.1, 0.5, 0.2, 0.9, 0.3, 0.0, 0.6, 0.4].map(Vec3::splat).to_vec();
        let tex = Texture::Bitmap(Arc::new(
            Bitmap::new(4, 2, h, FilterType::Bilinear, WrapMode::Repeat, Affine2::IDENTITY).unwrap(),
        ));
        let wi = Vec3::new(-0.3, 0.5, 1.0).normalize();
        for (w, plain, shadowed) in [
            (Vec3::new(0.1, 0.2, 1.0), 0.131651371717453, 0.1315271556377411),
            (Vec3::new(0.9, -0.8, 0.1), 0.13532762229442596, 0.13519994914531708),
        ] {
            let si = test_si(w);
            let rel = relative_frame(&si, &tex, 0.5).unwrap();
            let f = perturbed_frame(&si, &tex, 0.5);
            assert!((f.n - si.to_world(rel.n)).length() < 1e-6);
            assert!((f.s.cross(f.t) - f.n).length() < 1e-5);
            let got = wrapped_diffuse(&si, rel, wi, false);
            assert!((got - plain).abs() < 1e-5, "{w}: {got} vs {plain}");
            let got = wrapped_diffuse(&si, rel, wi, true);
            assert!((got - shadowed).abs() < 1e-5, "{w}: {got} vs {shadowed}");
        }
    }
}
