//! Integrators: estimate the radiance arriving along a camera ray.
//!
//! An integrator sees the scene only through [`Scene`]'s ray queries, BSDF
//! lookup and light sampling calls.

pub mod path;

pub use path::PathIntegrator;

use crate::geometry::Ray;
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use crate::scene::Scene;

/// Counters an integrator keeps per thread.
#[derive(Debug, Clone, Copy, Default)]
pub struct RayStats {
    /// Closest-hit queries (camera and bounce rays).
    pub rays: u64,
    /// Any-hit queries (shadow rays).
    pub shadow_rays: u64,
}

impl RayStats {
    pub fn add(&mut self, o: &RayStats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
    }
}

#[derive(Debug, Clone)]
pub enum Integrator {
    Path(PathIntegrator),
}

impl Integrator {
    /// Radiance along `ray` (a camera ray).
    #[inline]
    pub fn li(&self, scene: &Scene, ray: &Ray, rng: &mut SampleStream, stats: &mut RayStats) -> Spectrum {
        match self {
            Integrator::Path(p) => p.li(scene, ray, rng, stats),
        }
    }
}
