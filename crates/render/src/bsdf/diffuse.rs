//! Mitsuba `diffuse`: the Lambertian BRDF, one-sided.
//!
//! | parameter   | type | default |
//! |-------------|------|---------|
//! | reflectance | rgb  | 0.5     |

use super::BsdfSample;
use crate::math::{Spectrum, INV_PI};
use crate::sampling::warp;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Copy)]
pub struct Diffuse {
    pub reflectance: Spectrum,
}

impl Diffuse {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z > 0.0 && wi.z > 0.0 {
            self.reflectance * INV_PI
        } else {
            Spectrum::ZERO
        }
    }
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z > 0.0 && wi.z > 0.0 {
            warp::cosine_hemisphere_pdf(wi)
        } else {
            0.0
        }
    }
    /// Cosine-weighted sampling: weight f cos / p = reflectance.
    #[inline]
    pub fn sample(&self, wo: Vec3, u2: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = warp::sample_cosine_hemisphere(u2);
        let pdf = warp::cosine_hemisphere_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample { wi, pdf, weight: self.reflectance, delta: false, eta: 1.0 })
    }
}
