//! Mitsuba `roughplastic`. Placeholder: implemented in the microfacet change.

use super::microfacet::Microfacet;
use super::BsdfSample;
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// Per-material precomputation (depends on the distribution, alpha and eta
/// only, which Mitsuba requires to be constant).
#[derive(Debug, Clone)]
pub struct RoughPlasticTables {
    /// Rough-interface transmittance as a function of cos θ (64 entries on [0, 1]).
    pub external_transmittance: Vec<f32>,
    /// Hemispherical reflectance of the interface seen from inside.
    pub internal_reflectance: f32,
}

impl RoughPlasticTables {
    pub fn new(_distr: Microfacet, _eta: f32) -> RoughPlasticTables {
        RoughPlasticTables { external_transmittance: vec![1.0; 64], internal_reflectance: 0.0 }
    }
}

#[derive(Debug, Clone, Copy)]
pub struct RoughPlastic<'a> {
    pub distr: Microfacet,
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    pub diffuse_reflectance: Spectrum,
    pub specular_reflectance: Spectrum,
    pub nonlinear: bool,
    /// Mitsuba's `m_specular_sampling_weight`: s_mean / (d_mean + s_mean) of the textures' means.
    pub specular_sampling_weight: f32,
    pub tables: &'a RoughPlasticTables,
}

impl RoughPlastic<'_> {
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
