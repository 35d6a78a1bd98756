//! Mitsuba `constant`: uniform radiance from every direction at infinity,
//! sampled uniformly over the sphere (as Mitsuba does).
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | radiance  | rgb  | 1       |

use super::LightSample;
use crate::math::{Spectrum, PI};
use crate::sampling::warp;
use glam::Vec2;

/// Mitsuba's `constant` emitter.
#[derive(Debug, Clone)]
pub struct ConstantLight {
    /// Radiance arriving from every direction (W/(m² sr)).
    pub radiance: Spectrum,
}

impl ConstantLight {
    /// A uniform direction on the sphere: pdf 1/(4π), `li` = radiance, infinite distance.
    pub fn sample_li(&self, u2: Vec2) -> Option<LightSample> {
        let wi = warp::sample_uniform_sphere(u2);
        Some(LightSample { wi, dist: f32::INFINITY, pdf: warp::uniform_sphere_pdf(), li: self.radiance, delta: false })
    }

    /// Solid-angle density of `sample_li`, the same for every direction.
    pub fn pdf(&self) -> f32 {
        warp::uniform_sphere_pdf()
    }

    /// Φ = π (π r²) L through the scene's bounding disk, from every
    /// direction: 4π² r² L, for a scene of bounding radius `scene_radius`.
    pub fn power(&self, scene_radius: f32) -> Spectrum {
        4.0 * PI * PI * scene_radius * scene_radius * self.radiance
    }
}
