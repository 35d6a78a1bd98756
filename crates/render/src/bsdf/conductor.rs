//! Mitsuba `conductor`: a smooth metal mirror, one-sided.
//!
//! | parameter            | type | default |
//! |----------------------|------|---------|
//! | material             | name | none (a 100 % reflecting mirror) |
//! | eta, k               | rgb  | from `material` |
//! | specular_reflectance | rgb  | 1       |

use super::fresnel::{fresnel_conductor, reflect};
use super::BsdfSample;
use crate::math::Spectrum;
use glam::Vec3;

#[derive(Debug, Clone, Copy)]
pub struct Conductor {
    pub eta: Spectrum,
    pub k: Spectrum,
    pub specular_reflectance: Spectrum,
}

impl Conductor {
    #[inline]
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let f = fresnel_conductor(wo.z, self.eta, self.k);
        Some(BsdfSample { wi: reflect(wo), pdf: 1.0, weight: self.specular_reflectance * f, delta: true, eta: 1.0 })
    }
}
