//! Mitsuba `point`: an isotropic point light, a Dirac delta in position:
//! only light sampling can reach it (a BSDF-sampled ray never hits it).
//!
//! | parameter | type      | default |
//! |-----------|-----------|---------|
//! | position  | point     | the translation of `to_world` |
//! | to_world  | transform | identity (not together with `position`) |
//! | intensity | rgb       | 1 (W/sr) |

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::Aabb;
use crate::math::{luminance, Spectrum, PI};
use glam::Vec3;

/// Unit direction and distance from `from` to `to` (None if they coincide).
#[inline]
pub(super) fn towards(from: Vec3, to: Vec3) -> Option<(Vec3, f32)> {
    let d = to - from;
    let dist = d.length();
    (dist > 0.0).then(|| (d / dist, dist))
}

/// Mitsuba's `point` emitter.
#[derive(Debug, Clone)]
pub struct PointLight {
    /// Position in world space.
    pub position: Vec3,
    /// Radiant intensity I (W/sr), the same in every direction.
    pub intensity: Spectrum,
}

impl PointLight {
    /// Incident radiance is a delta: the sample's `li` is I / d², the
    /// irradiance-like weight the estimator uses with pdf 1.
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let (wi, dist) = towards(p_ref, self.position)?;
        Some(LightSample { wi, dist, pdf: 1.0, li: self.intensity / (dist * dist), delta: true })
    }

    /// Radiant flux Φ = 4π I.
    pub fn power(&self) -> Spectrum {
        4.0 * PI * self.intensity
    }

    /// Its position, emitting in every direction.
    pub fn bounds(&self) -> LightBounds {
        let at = Aabb { min: self.position, max: self.position };
        LightBounds::new(at, DirectionCone::ENTIRE_SPHERE, 0.0, luminance(self.power()))
    }
}
