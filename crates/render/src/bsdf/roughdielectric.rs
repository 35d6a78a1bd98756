//! Mitsuba `roughdielectric`. Placeholder: implemented in the microfacet change.

use super::microfacet::Microfacet;
use super::BsdfSample;
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Copy)]
pub struct RoughDielectric {
    pub distr: Microfacet,
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    pub specular_reflectance: Spectrum,
    pub specular_transmittance: Spectrum,
}

impl RoughDielectric {
    pub fn eval(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
    pub fn sample(&self, _wo: Vec3, _u: f32, _u2: Vec2) -> Option<BsdfSample> {
        None
    }
}
