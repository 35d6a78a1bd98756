//! Mitsuba `constant`: uniform radiance from every direction at infinity,
//! sampled uniformly over the sphere (as Mitsuba does).
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | radiance  | rgb  | 1       |

use super::LightSample;
use crate::math::Spectrum;
use crate::sampling::warp;
use glam::Vec2;

#[derive(Debug, Clone)]
pub struct ConstantLight {
    pub radiance: Spectrum,
}

impl ConstantLight {
    pub fn sample_li(&self, u2: Vec2) -> Option<LightSample> {
        let wi = warp::sample_uniform_sphere(u2);
        Some(LightSample { wi, dist: f32::INFINITY, pdf: warp::uniform_sphere_pdf(), li: self.radiance, delta: false })
    }
    pub fn pdf(&self) -> f32 {
        warp::uniform_sphere_pdf()
    }
}
