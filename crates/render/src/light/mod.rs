//! Emitters. Integrators reach them through [`crate::scene::Scene`]'s
//! `sample_light` / `light_pdf` / `emitted` calls, which add light selection.
//!
//! Contract: `pdf` values are densities per unit solid angle at the reference
//! point; `li` is the radiance arriving along `-wi`, unoccluded. For delta
//! lights (`delta` = true) `pdf` is 1 and `li` is the delta's weight (I/d² for
//! point and spot lights, E for directional ones), so `f · li · cos / pdf` is
//! the contribution in every case.

pub mod area;
pub mod bvh;
pub mod constant;
pub mod directional;
pub mod envmap;
pub mod point;
pub mod spot;

pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use envmap::EnvMapLight;
pub use point::PointLight;
pub use spot::SpotLight;

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
    Point(PointLight),
    Spot(SpotLight),
    Directional(DirectionalLight),
    EnvMap(EnvMapLight),
}

impl Light {
    pub fn sample_li(&self, p_ref: Vec3, u2: Vec2, shapes: &[Shape]) -> Option<LightSample> {
        match self {
            Light::Area(a) => a.sample_li(p_ref, u2, &shapes[a.shape as usize]),
            Light::Constant(c) => c.sample_li(u2),
            Light::Point(p) => p.sample_li(p_ref),
            Light::Spot(s) => s.sample_li(p_ref),
            Light::Directional(d) => d.sample_li(),
            Light::EnvMap(e) => e.sample_li(u2),
        }
    }

    /// Whether this light is at infinity (hit by rays that escape the scene).
    pub fn is_environment(&self) -> bool {
        matches!(self, Light::Constant(_) | Light::EnvMap(_))
    }

    /// Radiance from direction `wi` for lights at infinity (zero otherwise),
    /// and the solid-angle density with which `sample_li` picks `wi`.
    #[inline]
    pub fn environment(&self, wi: Vec3) -> (Spectrum, f32) {
        match self {
            Light::Constant(c) => (c.radiance, c.pdf()),
            Light::EnvMap(e) => e.eval_pdf(wi),
            _ => (Spectrum::ZERO, 0.0),
        }
    }

    /// [`Self::environment`] without the density, for paths whose last
    /// vertex was the camera or a specular bounce (no MIS weight to form).
    #[inline]
    pub fn environment_radiance(&self, wi: Vec3) -> Spectrum {
        match self {
            Light::Constant(c) => c.radiance,
            Light::EnvMap(e) => e.eval(wi),
            _ => Spectrum::ZERO,
        }
    }

    /// Dirac-delta lights (point, spot, directional): reachable only by light sampling.
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point(_) | Light::Spot(_) | Light::Directional(_))
    }

    /// Emitted flux (luminance is used to weight power-based selection).
    /// `scene_radius` bounds the scene, for lights at infinity.
    pub fn power(&self, shapes: &[Shape], scene_radius: f32) -> Spectrum {
        use crate::math::PI;
        match self {
            // Φ = π A L for a one-sided diffuse emitter.
            Light::Area(a) => PI * shapes[a.shape as usize].area() * a.radiance,
            // Φ = π (π r²) L through the scene's bounding disk, from every direction: 4π² r² L.
            Light::Constant(c) => 4.0 * PI * PI * scene_radius * scene_radius * c.radiance,
            Light::Point(p) => p.power(),
            Light::Spot(s) => s.power(),
            Light::Directional(d) => d.power(),
            Light::EnvMap(e) => 4.0 * PI * PI * scene_radius * scene_radius * e.mean_radiance(),
        }
    }
}
