//! Mitsuba `dielectric`: a smooth interface between two dielectrics.
//!
//! | parameter                 | type          | default |
//! |---------------------------|---------------|---------|
//! | int_ior                   | float or name | bk7     |
//! | ext_ior                   | float or name | air     |
//! | specular_reflectance      | rgb           | 1       |
//! | specular_transmittance    | rgb           | 1       |

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `dielectric` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct Dielectric {
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Spectrum,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Spectrum,
}

/// Mitsuba `dielectric` as the scene stores it.
#[derive(Debug, Clone)]
pub struct DielectricParams {
    /// Relative IOR (interior / exterior).
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Texture,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Texture,
}

impl BsdfParams for DielectricParams {
    type Model<'a> = Dielectric;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> Dielectric {
        Dielectric {
            eta: self.eta,
            specular_reflectance: self.specular_reflectance.eval(si),
            specular_transmittance: self.specular_transmittance.eval(si),
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.specular_reflectance, &self.specular_transmittance]
    }
}

impl BsdfModel for Dielectric {
    #[inline]
    fn has_smooth(&self) -> bool {
        false
    }

    /// Chooses reflection with probability F, refraction otherwise, so the
    /// weight is the tint alone; in radiance transport refraction scales by
    /// 1/η² (Veach 1997, §5.2; Mitsuba's `dielectric.cpp`).
    #[inline]
    fn sample(&self, wo: Vec3, u: f32, _u2: Vec2) -> Option<BsdfSample> {
        let (r, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, self.eta);
        if u <= r {
            Some(BsdfSample {
                wi: reflect(wo),
                pdf: r,
                weight: self.specular_reflectance,
                delta: true,
                null: false,
                eta: 1.0,
            })
        } else {
            let wi = refract(wo, cos_t, eta_ti);
            Some(BsdfSample {
                wi,
                pdf: 1.0 - r,
                weight: self.specular_transmittance * (eta_ti * eta_ti),
                delta: true,
                null: false,
                eta: eta_it,
            })
        }
    }
}
