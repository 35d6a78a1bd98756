//! Mitsuba `conductor`: a smooth metal mirror, one-sided.
//!
//! | parameter            | type | default |
//! |----------------------|------|---------|
//! | material             | name | none (a 100 % reflecting mirror) |
//! | eta, k               | rgb  | from `material` |
//! | specular_reflectance | rgb  | 1       |

use super::fresnel::{fresnel_conductor, reflect};
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `conductor` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct Conductor {
    /// Real part of the relative complex IOR, per channel.
    pub eta: Spectrum,
    /// Imaginary part (absorption) of the relative complex IOR, per channel.
    pub k: Spectrum,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Spectrum,
}

/// Mitsuba `conductor` as the scene stores it.
#[derive(Debug, Clone)]
pub struct ConductorParams {
    /// Real part of the relative complex IOR.
    pub eta: Texture,
    /// Imaginary part (absorption) of the relative complex IOR.
    pub k: Texture,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Texture,
}

impl BsdfParams for ConductorParams {
    type Model<'a> = Conductor;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> Conductor {
        Conductor {
            eta: self.eta.eval(si),
            k: self.k.eval(si),
            specular_reflectance: self.specular_reflectance.eval(si),
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.eta, &self.k, &self.specular_reflectance]
    }
}

impl BsdfModel for Conductor {
    #[inline]
    fn has_smooth(&self) -> bool {
        false
    }

    #[inline]
    fn sample(&self, wo: Vec3, _u: f32, _u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f = fresnel_conductor(wo.z, self.eta, self.k);
        Some(BsdfSample {
            wi: reflect(wo),
            pdf: 1.0,
            weight: self.specular_reflectance * f,
            delta: true,
            null: false,
            eta: 1.0,
        })
    }
}
