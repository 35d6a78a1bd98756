//! Arbitrary output variables (AOVs): per-sample auxiliary values at a camera
//! ray's hits, accumulated in the film beside the beauty image as additive
//! weighted sums (Σ w·a), so passes, resume and parts treat them as the beauty.
//!
//! Names follow Mitsuba's `aov` integrator where it has them:
//! - `albedo`: the directional albedo ∫ f |cos| dω of the first non-delta
//!   surface, estimated with one BSDF sample (for a diffuse surface exactly
//!   its reflectance; Mitsuba's `albedo` reports the diffuse reflectance).
//! - `normal`: the world-space shading normal there (Mitsuba's `sh_normal`,
//!   after normal and bump maps and `twosided`).
//!
//! Both are taken *through* delta (perfectly specular or null/masked)
//! surfaces: the query follows the sampled delta lobe to the first
//! non-delta hit, as Open Image Denoise recommends for its guides, and
//! reports that surface's values unweighted (a perfect mirror shows the
//! albedo of what it reflects). A ray that escapes reports zero.
//! - `depth`: distance from the camera to the first hit (Mitsuba's `depth`:
//!   from the pinhole or the lens point, not from the near clip plane where
//!   rays start; from the near plane for orthographic cameras; 0 where the ray escapes).
//! - `position`: world-space position of the first hit (0 where it escapes).
//!
//! The query uses its own random numbers (a stream keyed apart from the
//! pixel's), so requesting AOVs never changes the beauty image.

use super::{camera_hit, Integrator, RayStats};
use crate::film::aov::AovSample;
use crate::geometry::Ray;
use crate::material::Scratch;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use glam::Vec3;

/// Delta surfaces followed at most before giving up (reporting zero).
const MAX_DELTA_CHAIN: u32 = 16;

fn hide_emitters(integrator: &Integrator) -> bool {
    match integrator {
        Integrator::Path(p) => p.hide_emitters,
        Integrator::Direct(d) => d.hide_emitters,
        Integrator::BruteForce(b) => b.hide_emitters,
        Integrator::VolPath(v) => v.hide_emitters,
        Integrator::Depth(_) => false,
        Integrator::PTracer(p) => p.hide_emitters,
        Integrator::Aov(a) => a.integrators.first().is_some_and(|(_, i)| hide_emitters(i)),
        Integrator::Moment(m) => m.integrators.first().is_some_and(|(_, i)| hide_emitters(i)),
    }
}

/// The AOVs of camera ray `ray` leaving the camera at `eye` (depth is
/// measured from there), with random numbers from `rng` (BSDFs may allocate in `scratch`).
pub fn query(
    scene: &Scene,
    integrator: &Integrator,
    ray: &Ray,
    eye: Vec3,
    rng: &mut SampleStream,
    scratch: &Scratch,
) -> AovSample {
    let mut out = AovSample::default();
    let mut stats = RayStats::default();
    let Some(mut si) = camera_hit(scene, ray, hide_emitters(integrator), &mut stats) else {
        return out;
    };
    out.depth = (si.p - eye).length();
    out.position = si.p.to_array();
    for _ in 0..MAX_DELTA_CHAIN {
        let bsdf = scene.bsdf(&mut si, scratch);
        let wo = si.to_local(si.wo);
        let (u, u2) = (rng.next_1d(), rng.next_2d());
        if bsdf.has_smooth() {
            out.normal = si.sh_frame.n.to_array();
            if let Some(bs) = bsdf.sample(wo, u, u2) {
                // A delta lobe of a mixed BSDF (plastic's specular coat,
                // a mask's pass-through) is part of the surface's albedo.
                if bs.weight.is_finite() {
                    out.albedo = bs.weight.to_array();
                }
            }
            return out;
        }
        // Purely delta: follow the sampled lobe.
        let Some(bs) = bsdf.sample(wo, u, u2) else { return out };
        let next = scene.spawn_ray(&si, si.to_world(bs.wi));
        match scene.intersect(&next) {
            Some(s) => si = s,
            None => return out,
        }
    }
    out
}
