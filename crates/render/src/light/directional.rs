//! Mitsuba `directional`: light arriving from one direction with constant
//! irradiance, a Dirac delta in direction (only light sampling reaches it).
//!
//! | parameter  | type      | default |
//! |------------|-----------|---------|
//! | direction  | vector    | local +z of `to_world` (normalised): the direction light travels |
//! | to_world   | transform | identity (not together with `direction`) |
//! | irradiance | rgb       | 1 (W/m²) |

use super::LightSample;
use crate::math::{Spectrum, PI};
use glam::Vec3;

/// Mitsuba's `directional` emitter.
#[derive(Debug, Clone)]
pub struct DirectionalLight {
    /// Unit direction in which the light travels.
    pub direction: Vec3,
    /// Irradiance E (W/m²) on a surface facing the light.
    pub irradiance: Spectrum,
    /// Radius of the scene's bounding sphere (for `power`), given at
    /// construction: the scene builder makes lights once the geometry's
    /// bounds are known.
    pub scene_radius: f32,
}

impl DirectionalLight {
    /// The one direction `-direction`, as a delta: pdf 1, `li` = E, infinite distance.
    pub fn sample_li(&self) -> Option<LightSample> {
        Some(LightSample { wi: -self.direction, dist: f32::INFINITY, pdf: 1.0, li: self.irradiance, delta: true })
    }

    /// Flux through the scene's bounding disk: π r² E.
    pub fn power(&self) -> Spectrum {
        PI * self.scene_radius * self.scene_radius * self.irradiance
    }
}
