//! Mitsuba's `checkerboard` texture: two colours (each possibly a texture)
//! alternating on the unit squares of (transformed) uv space.

use super::Texture;
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use glam::{Affine2, Vec2};

/// Mitsuba's `checkerboard` texture.
#[derive(Debug, Clone)]
pub struct Checkerboard {
    /// Default 0.4 in Mitsuba.
    pub color0: Texture,
    /// Default 0.2 in Mitsuba.
    pub color1: Texture,
    /// Mitsuba's `to_uv`, applied to the surface uv.
    pub to_uv: Affine2,
}

impl Checkerboard {
    /// Whether the fractional parts of u and v fall on the same side of 1/2.
    #[inline]
    fn same_half(&self, uv: Vec2) -> bool {
        let uv = self.to_uv.transform_point2(uv);
        let f = uv - uv.floor();
        (f.x > 0.5) == (f.y > 0.5)
    }

    /// `color0` where the fractional parts of u and v are on the same side of
    /// 1/2, `color1` elsewhere (Mitsuba 3.9.1's `eval`).
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction) -> Spectrum {
        if self.same_half(si.uv) {
            self.color0.eval(si)
        } else {
            self.color1.eval(si)
        }
    }

    /// Mitsuba 3.9.1's `eval_1` picks `color0` where the halves *differ*:
    /// the opposite squares from `eval`. Reproduced as is, since a textured
    /// roughness or opacity then matches Mitsuba's image.
    #[inline]
    pub fn eval_1(&self, si: &SurfaceInteraction) -> f32 {
        if self.same_half(si.uv) {
            self.color1.eval_1(si)
        } else {
            self.color0.eval_1(si)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat2, Vec3};

    fn si(u: f32, v: f32) -> SurfaceInteraction {
        SurfaceInteraction::at_uv(Vec2::new(u, v))
    }

    // Mitsuba 3.9.1 (scalar_rgb):
    //   t = mi.load_dict({'type': 'checkerboard', 'color0': {'type': 'rgb', 'value': [0.9, 0.1, 0.1]},
    //                     'color1': 0.25, 'to_uv': mi.ScalarTransform4f().scale([3, 2, 1])})
    //   t.eval(si), t.eval_1(si), t.mean(); mi.load_dict({'type': 'checkerboard'}).mean() = 0.3
    #[test]
    fn checkerboard_matches_mitsuba_including_swapped_eval_1() {
        let c = Checkerboard {
            color0: Texture::Constant(Vec3::new(0.9, 0.1, 0.1)),
            color1: Texture::Constant(Vec3::splat(0.25)),
            to_uv: Affine2::from_mat2(Mat2::from_diagonal(Vec2::new(3.0, 2.0))),
        };
        let c0 = Vec3::new(0.9, 0.1, 0.1);
        let c1 = Vec3::splat(0.25);
        for ((u, v), rgb, e1) in [
            ((0.1, 0.1), c0, 0.25),
            ((0.2, 0.1), c1, 0.36666667),
            ((0.1, 0.3), c1, 0.36666667),
            ((0.2, 0.3), c0, 0.25),
            ((-0.05, 0.6), c1, 0.36666667),
        ] {
            assert!((c.eval(&si(u, v)) - rgb).abs().max_element() < 1e-6, "({u},{v})");
            assert!((c.eval_1(&si(u, v)) - e1).abs() < 1e-6, "({u},{v})");
        }
        let t = Texture::Checkerboard(std::sync::Arc::new(c));
        assert!((t.mean() - 0.30833334).abs() < 1e-6);
    }
}
