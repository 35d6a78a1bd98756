//! Emitters. Integrators reach them through [`crate::scene::Scene`]'s
//! `sample_light` / `light_pdf` / `emitted` calls, which add light selection.
//!
//! Contract: `pdf` values are densities per unit solid angle at the reference
//! point; `li` is the radiance arriving along `-wi`, unoccluded.

pub mod area;
pub mod constant;

pub use area::AreaLight;
pub use constant::ConstantLight;

use crate::geometry::Shape;
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// A direction sampled towards a light from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for environment lights).
    pub dist: f32,
    /// Density per unit solid angle (not including light selection).
    pub pdf: f32,
    /// Emitted radiance towards the reference point.
    pub li: Spectrum,
    /// Dirac-delta light (point, spot, directional): MIS does not apply.
    pub delta: bool,
}

#[derive(Debug, Clone)]
pub enum Light {
    Area(AreaLight),
    Constant(ConstantLight),
}

impl Light {
    pub fn sample_li(&self, p_ref: Vec3, u2: Vec2, shapes: &[Shape]) -> Option<LightSample> {
        match self {
            Light::Area(a) => a.sample_li(p_ref, u2, &shapes[a.shape as usize]),
            Light::Constant(c) => c.sample_li(u2),
        }
    }

    /// Whether this light is at infinity (hit by rays that escape the scene).
    pub fn is_environment(&self) -> bool {
        matches!(self, Light::Constant(_))
    }
}
