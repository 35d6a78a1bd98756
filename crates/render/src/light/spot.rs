//! Mitsuba `spot`: a point light emitting along its local +z inside a cone.
//! Full intensity inside `beam_width`, falling off linearly in angle to zero
//! at `cutoff_angle` (Mitsuba's `falloff_curve`).
//!
//! | parameter    | type      | default |
//! |--------------|-----------|---------|
//! | to_world     | transform | identity (position and orientation) |
//! | intensity    | rgb       | 1 (W/sr) |
//! | cutoff_angle | float     | 20 (degrees) |
//! | beam_width   | float     | 3/4 of cutoff_angle (degrees) |

use super::LightSample;
use crate::math::{safe_acos, Mat4, Spectrum, PI};
use glam::Vec3;

#[derive(Debug, Clone)]
pub struct SpotLight {
    pub position: Vec3,
    /// World to light-local rotation (local +z is the beam axis).
    pub light_from_world: Mat4,
    pub intensity: Spectrum,
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
}

impl SpotLight {
    /// Angles in degrees, as in the scene file.
    pub fn new(world_from_light: Mat4, intensity: Spectrum, cutoff_deg: f32, beam_deg: f32) -> SpotLight {
        let (cutoff, beam) = (cutoff_deg.to_radians(), beam_deg.to_radians());
        SpotLight {
            position: world_from_light.transform_point3(Vec3::ZERO),
            light_from_world: world_from_light.inverse(),
            intensity,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
        }
    }

    /// Angular falloff for a local direction `d` (unit).
    #[inline]
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - safe_acos(cos_theta)) * self.inv_transition
        }
    }

    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let (wi, dist) = super::point::towards(p_ref, self.position)?;
        let dist2 = dist * dist;
        let local = self.light_from_world.transform_vector3(-wi).normalize();
        let f = self.falloff(local.z);
        if f <= 0.0 {
            return None;
        }
        Some(LightSample { wi, dist, pdf: 1.0, li: self.intensity * (f / dist2), delta: true })
    }

    /// Flux: ∫ I f(θ) dω = 2π I ∫ f(θ) sin θ dθ, integrated numerically
    /// (only used to weight light selection).
    pub fn power(&self) -> Spectrum {
        let n = 256;
        let mut acc = 0.0;
        for i in 0..n {
            let t = (i as f32 + 0.5) / n as f32 * self.cutoff;
            acc += self.falloff(t.cos()) * t.sin();
        }
        self.intensity * (2.0 * PI * acc * self.cutoff / n as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falloff_matches_mitsubas_curve() {
        let s = SpotLight::new(Mat4::IDENTITY, Spectrum::ONE, 20.0, 10.0);
        assert_eq!(s.falloff(5f32.to_radians().cos()), 1.0);
        assert!((s.falloff(15f32.to_radians().cos()) - 0.5).abs() < 1e-4);
        assert_eq!(s.falloff(25f32.to_radians().cos()), 0.0);
        // Seen along its axis from 2 units away: I / d².
        let s = SpotLight::new(Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0)), Spectrum::splat(8.0), 20.0, 15.0);
        let ls = s.sample_li(Vec3::ZERO).unwrap();
        assert!((ls.li - Spectrum::splat(2.0)).abs().max_element() < 1e-5 && ls.delta);
        assert!(s.sample_li(Vec3::new(0.0, 5.0, 0.0)).is_none(), "outside the cone");
    }
}
