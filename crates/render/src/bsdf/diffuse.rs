//! Mitsuba `diffuse`: the Lambertian BRDF, one-sided.
//!
//! | parameter   | type | default |
//! |-------------|------|---------|
//! | reflectance | rgb  | 0.5     |

use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, INV_PI};
use crate::sampling::warp;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `diffuse` with its texture evaluated at a hit: f = reflectance / π.
#[derive(Debug, Clone, Copy)]
pub struct Diffuse {
    /// Albedo ρ (linear RGB).
    pub reflectance: Spectrum,
}

/// Mitsuba `diffuse` as the scene stores it.
#[derive(Debug, Clone)]
pub struct DiffuseParams {
    /// Albedo ρ.
    pub reflectance: Texture,
}

impl BsdfParams for DiffuseParams {
    type Model<'a> = Diffuse;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> Diffuse {
        Diffuse { reflectance: self.reflectance.eval(si) }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.reflectance]
    }
}

impl BsdfModel for Diffuse {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z > 0.0 && wi.z > 0.0 {
            self.reflectance * INV_PI
        } else {
            Spectrum::ZERO
        }
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z > 0.0 && wi.z > 0.0 {
            warp::cosine_hemisphere_pdf(wi)
        } else {
            0.0
        }
    }

    /// Cosine-weighted sampling: weight f cos / p = reflectance.
    #[inline]
    fn sample(&self, wo: Vec3, _u: f32, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = warp::sample_cosine_hemisphere(u2);
        let pdf = warp::cosine_hemisphere_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample { wi, pdf, weight: self.reflectance, delta: false, null: false, eta: 1.0 })
    }
}
