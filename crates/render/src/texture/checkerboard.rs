//! Mitsuba's `checkerboard` texture: two colours (each possibly a texture)
//! alternating on the unit squares of (transformed) uv space.

use super::Texture;
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use glam::{Affine2, Vec2};

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
