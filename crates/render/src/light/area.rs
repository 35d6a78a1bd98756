//! Mitsuba `area`: a diffuse emitter attached to a shape, emitting
//! `radiance` from the shape's front side only.
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | radiance  | rgb  | (required) |

use super::LightSample;
use crate::geometry::Shape;
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone)]
pub struct AreaLight {
    pub shape: u32,
    pub radiance: Spectrum,
}

impl AreaLight {
    /// Radiance leaving the surface with front normal `n` towards `w`.
    #[inline]
    pub fn emitted(&self, n: Vec3, w: Vec3) -> Spectrum {
        if n.dot(w) > 0.0 {
            self.radiance
        } else {
            Spectrum::ZERO
        }
    }

    pub fn sample_li(&self, p_ref: Vec3, u2: Vec2, shape: &Shape) -> Option<LightSample> {
        let s = shape.sample_direction(p_ref, u2)?;
        let d = s.p - p_ref;
        let dist = d.length();
        if dist == 0.0 || !(s.pdf > 0.0) || !s.pdf.is_finite() {
            return None;
        }
        let wi = d / dist;
        let li = self.emitted(s.n, -wi);
        if li == Spectrum::ZERO {
            return None;
        }
        Some(LightSample { wi, dist, pdf: s.pdf, li, delta: false })
    }
}
