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
//!
//! The angles must satisfy 0 ≤ beam_width < cutoff_angle ≤ 180.
//!
//! [`SpotLight::pbrt`] makes pbrt-v4's `spot` instead: the falloff is
//! smoothstep(cos θ) from cos(coneangle) (0) to cos(coneangle −
//! conedeltaangle) (1), a hard edge when the two coincide (pbrt-v4's
//! `SpotLight::I` and `SmoothStep`).

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::Aabb;
use crate::math::{luminance, Mat3, Mat4, Spectrum, PI};
use crate::texture::Bitmap;
use glam::Vec3;
use std::sync::Arc;

/// Mitsuba's `spot` emitter.
#[derive(Debug, Clone)]
pub struct SpotLight {
    /// Position in world space (the translation of `to_world`).
    pub position: Vec3,
    /// World to light-local rotation (local +z is the beam axis).
    pub light_from_world: Mat4,
    /// Radiant intensity I (W/sr) inside `beam_width`, before the falloff.
    pub intensity: Spectrum,
    cutoff: f32,
    /// Mitsuba's `texture`: an image projected through the cone, looked up
    /// at uv = ½ + ½ (x, y) / (z tan(cutoff)) of the local direction.
    pub texture: Option<Arc<Bitmap>>,
    /// cos of the cutoff angle: the cone outside which it emits nothing.
    pub cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
    /// pbrt-v4's smoothstep falloff in cos θ instead of Mitsuba's linear one in θ.
    smooth: bool,
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
            texture: None,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
            smooth: false,
        }
    }

    /// pbrt-v4's `spot`: full intensity inside `cone_deg − delta_deg`, a
    /// smoothstep in cos θ down to zero at `cone_deg` (angles in degrees,
    /// 0 ≤ delta_deg ≤ cone_deg ≤ 180).
    pub fn pbrt(world_from_light: Mat4, intensity: Spectrum, cone_deg: f32, delta_deg: f32) -> SpotLight {
        SpotLight { smooth: true, ..SpotLight::new(world_from_light, intensity, cone_deg, cone_deg - delta_deg) }
    }

    /// Angular falloff at `cos_theta` from the beam axis (light-local z).
    #[inline]
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        if self.smooth {
            // pbrt-v4's SmoothStep(cos_cutoff, cos_beam, cos θ).
            let (a, b) = (self.cos_cutoff, self.cos_beam);
            if a == b {
                return if cos_theta < a { 0.0 } else { 1.0 };
            }
            let t = ((cos_theta - a) / (b - a)).clamp(0.0, 1.0);
            return t * t * (3.0 - 2.0 * t);
        }
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - crate::simd::acos(cos_theta)) * self.inv_transition
        }
    }

    /// The direction to the light as a delta: pdf 1, `li` = I·falloff / d²;
    /// `None` outside the cone (or at the light's position).
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let (wi, dist) = super::point::towards(p_ref, self.position)?;
        let dist2 = dist * dist;
        let local = self.light_from_world.transform_vector3(-wi).normalize();
        let f = self.falloff(local.z);
        if f <= 0.0 {
            return None;
        }
        let mut li = self.intensity * (f / dist2);
        if let Some(t) = &self.texture {
            // Mitsuba's direction_to_uv, with uv_factor = tan(cutoff).
            let k = 0.5 / (local.z * self.cutoff.tan());
            li *= t.eval(glam::Vec2::new(0.5 + local.x * k, 0.5 + local.y * k));
        }
        Some(LightSample { wi, dist, pdf: 1.0, li, delta: true })
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

    /// Its position and beam: the cone of axes is the beam axis alone
    /// (θ_o = 0) and emission spreads up to the cutoff angle around it (θ_e).
    /// φ is 4π I as in pbrt, not the cone's flux, so that a spot light
    /// compares with a point light of the same intensity. Without a circular
    /// beam (a non-uniformly scaled `to_world`) the bounds hold every
    /// direction; a spot light that emits nothing gets φ = 0.
    pub fn bounds(&self) -> LightBounds {
        let at = Aabb { min: self.position, max: self.position };
        let Some(cos_cutoff) = self.cos_cutoff_bound() else {
            return LightBounds::new(at, DirectionCone::ENTIRE_SPHERE, 0.0, 0.0);
        };
        let (cone, cos_theta_e) = match self.beam_axis() {
            Some(w) => (DirectionCone { w, cos_theta: 1.0 }, cos_cutoff),
            None => (DirectionCone::ENTIRE_SPHERE, 0.0),
        };
        LightBounds::new(at, cone, cos_theta_e, 4.0 * PI * luminance(self.intensity))
    }

    /// World-space beam axis, or None when the transform is not a rotation
    /// times a uniform scale (the beam is then not a circular cone).
    fn beam_axis(&self) -> Option<Vec3> {
        let m = Mat3::from_mat4(self.light_from_world);
        let g = m * m.transpose();
        let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
        let dev = (g - Mat3::from_diagonal(Vec3::splat(s2))).to_cols_array().iter().fold(0.0f32, |a, x| a.max(x.abs()));
        // With M Mᵀ = s² I, local z of M d is cos(d, Mᵀ ẑ) |Mᵀ ẑ|.
        (s2 > 0.0 && dev <= 1e-4 * s2).then(|| m.transpose().mul_vec3(Vec3::Z).normalize())
    }

    /// The cosine where `falloff` turns positive, found by bisection on
    /// `falloff` as evaluated (the tightest bound; it can lie a few ulps above
    /// `cos_cutoff` where acos rounds): the returned cosine has zero falloff,
    /// larger ones up to 1 have positive falloff. None if the light emits
    /// nothing.
    fn cos_cutoff_bound(&self) -> Option<f32> {
        let emits = self.falloff(1.0) > 0.0;
        if !emits {
            return None;
        }
        if self.falloff(-1.0) > 0.0 {
            return Some(-1.0);
        }
        let (mut lo, mut hi) = (-1.0f32, 1.0f32);
        loop {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                return Some(lo);
            }
            if self.falloff(mid) > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pbrt_falloff_is_a_smoothstep_in_cos_and_its_power_closed_form() {
        let s = SpotLight::pbrt(Mat4::IDENTITY, Spectrum::splat(2.0), 30.0, 10.0);
        let (a, b) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
        assert_eq!(s.falloff(10f32.to_radians().cos()), 1.0);
        assert_eq!(s.falloff(31f32.to_radians().cos()), 0.0);
        for deg in [21.0f32, 25.0, 29.0] {
            let t = (deg.to_radians().cos() - a) / (b - a);
            let want = t * t * (3.0 - 2.0 * t);
            assert!((s.falloff(deg.to_radians().cos()) - want).abs() < 1e-5, "{deg}");
        }
        // The smoothstep integrates to half its interval in cos θ: Φ = 2π I ((1 - b) + (b - a) / 2),
        // the k_e pbrt-v4 divides `power` by. The numerical flux must agree.
        let want = 2.0 * PI * 2.0 * ((1.0 - b) + (b - a) / 2.0);
        let got = s.power().x;
        assert!((got - want).abs() < 2e-3 * want, "{got} vs {want}");
        // No transition: a hard edge.
        let s = SpotLight::pbrt(Mat4::IDENTITY, Spectrum::ONE, 30.0, 0.0);
        assert_eq!(s.falloff(29.9f32.to_radians().cos()), 1.0);
        assert_eq!(s.falloff(30.1f32.to_radians().cos()), 0.0);
    }

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
