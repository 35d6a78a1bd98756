//! Mitsuba `depth`: the distance along each camera ray to its first
//! surface (0 where it escapes), in every channel; no parameters. Every
//! surface counts, emitters and `null` ones included, as in Mitsuba's
//! `ray_intersect_preliminary`. Distances start where the camera ray does
//! (on the near clip plane for perspective cameras, as Mitsuba's do).

use super::RayStats;
use crate::geometry::Ray;
use crate::math::Spectrum;
use crate::scene::Scene;

/// The `depth` integrator (no parameters).
#[derive(Debug, Clone, Default)]
pub struct DepthIntegrator;

impl DepthIntegrator {
    /// The first hit's distance along `ray`, or 0.
    pub fn li(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> Spectrum {
        stats.rays += 1;
        scene.intersect(ray).map_or(Spectrum::ZERO, |si| Spectrum::splat(si.t))
    }
}
