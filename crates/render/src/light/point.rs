//! Mitsuba `point`: an isotropic point light, a Dirac delta in position:
//! only light sampling can reach it (a BSDF-sampled ray never hits it).
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | position  | point | (or the translation of `to_world`) |
//! | intensity | rgb  | 1 (W/sr) |

use super::LightSample;
use crate::math::{Spectrum, PI};
use glam::Vec3;

#[derive(Debug, Clone)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Spectrum,
}

impl PointLight {
    /// Incident radiance is a delta: the sample's `li` is I / d², the
    /// irradiance-like weight the estimator uses with pdf 1.
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let d = self.position - p_ref;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        Some(LightSample { wi: d / dist, dist, pdf: 1.0, li: self.intensity / dist2, delta: true })
    }

    /// Radiant flux Φ = 4π I.
    pub fn power(&self) -> Spectrum {
        4.0 * PI * self.intensity
    }
}
