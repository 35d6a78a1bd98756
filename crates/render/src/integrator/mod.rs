//! Integrators: estimate the radiance arriving along a camera ray.
//!
//! An integrator sees the scene only through [`Scene`]'s ray queries, BSDF
//! lookup and light sampling calls.
//!
//! | integrator   | estimator |
//! |--------------|-----------|
//! | `path`       | light sampling + BSDF sampling at every vertex, MIS (or the split without it) |
//! | `direct`     | direct illumination only: N light samples + M BSDF samples, MIS (Mitsuba `direct`) |
//! | `bruteforce` | hemisphere form only: one sampled direction per vertex, emission only when hit |
//! | `depth`      | the distance to the first surface (Mitsuba `depth`) |
//! | `volpath`    | `path` through participating media: free-flight sampling, transmittance on shadow rays (Mitsuba `volpath`, `volpathmis`) |

pub mod aov;
pub mod bruteforce;
pub mod depth;
pub mod direct;
pub mod path;
pub mod volpath;

pub use bruteforce::{BruteForceIntegrator, HemisphereSampling};
pub use depth::DepthIntegrator;
pub use direct::DirectIntegrator;
pub use path::PathIntegrator;
pub use volpath::VolPathIntegrator;

use crate::geometry::Ray;
use crate::material::Scratch;
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
    /// Packets the stream integrator traced (closest-hit and shadow); zero
    /// for the one-path loop.
    pub packets: u64,
    /// The lanes those packets offered (packets × lane width): the rays
    /// above over these lanes is the lane occupancy.
    pub packet_lanes: u64,
}

impl RayStats {
    /// Adds another thread's counts.
    pub fn add(&mut self, o: &RayStats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.packets += o.packets;
        self.packet_lanes += o.packet_lanes;
    }
}

/// First hit of a camera ray. With `hide_emitters`, camera rays pass
/// through area emitters (as Mitsuba 3 does), revealing what lies behind
/// them; every integrator uses this, so they agree on hidden emitters.
#[inline]
pub(crate) fn camera_hit(
    scene: &Scene,
    ray: &Ray,
    hide_emitters: bool,
    stats: &mut RayStats,
) -> Option<crate::geometry::SurfaceInteraction> {
    stats.rays += 1;
    let mut hit = scene.intersect(ray);
    if hide_emitters {
        while let Some(si) = hit {
            if scene.shape_info[si.shape as usize].light.is_none() {
                return Some(si);
            }
            stats.rays += 1;
            hit = scene.intersect(&scene.spawn_ray(&si, ray.d));
        }
    }
    hit
}

/// Path termination shared by the multi-bounce integrators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Termination {
    /// Longest path in segments (Mitsuba's count); `u32::MAX` for unbounded.
    pub max_depth: u32,
    /// Depth from which Russian roulette plays.
    pub rr_depth: u32,
    /// Stop once max(β) falls below this (0 = off). Biased: the energy of the
    /// cut paths is lost, unlike Russian roulette.
    pub throughput_threshold: f32,
}

impl Default for Termination {
    fn default() -> Self {
        Termination { max_depth: u32::MAX, rr_depth: 5, throughput_threshold: 0.0 }
    }
}

impl Termination {
    /// Decides whether a path with throughput `beta` that has just completed
    /// `depth` segments goes on. Returns the survival probability to divide
    /// β by (1 when roulette did not play), or `None` to stop.
    /// Roulette as Mitsuba: survival q = min(0.95, max(β) η²) from `rr_depth` on.
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn survive(&self, beta: Spectrum, eta: f32, depth: u32, rng: &mut SampleStream) -> Option<f32> {
        let beta_max = beta.max_element();
        if !(beta_max > 0.0) || beta_max < self.throughput_threshold {
            return None;
        }
        if depth < self.rr_depth {
            return Some(1.0);
        }
        let q = (beta_max * eta * eta).min(0.95);
        (rng.next_1d() < q).then_some(q)
    }
}

/// The scene's integrator: one variant per plugin (see the module docs).
#[derive(Debug, Clone)]
pub enum Integrator {
    /// `path`: NEE + BSDF sampling, MIS, Russian roulette.
    Path(PathIntegrator),
    /// `direct`: direct illumination at the first hit.
    Direct(DirectIntegrator),
    /// `bruteforce`: one sampled direction per vertex, no light sampling.
    BruteForce(BruteForceIntegrator),
    /// `volpath` / `volpathmis`: path tracing through participating media.
    VolPath(VolPathIntegrator),
    /// `depth`: the distance to the first surface.
    Depth(DepthIntegrator),
}

impl Integrator {
    /// Radiance along `ray` (a camera ray). The BSDFs of its hits may
    /// allocate in `scratch`, which the caller resets between samples.
    #[inline]
    pub fn li(
        &self,
        scene: &Scene,
        ray: &Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        match self {
            Integrator::Path(p) => p.li(scene, ray, rng, stats, scratch),
            Integrator::Direct(d) => d.li(scene, ray, rng, stats, scratch),
            Integrator::BruteForce(b) => b.li(scene, ray, rng, stats, scratch),
            Integrator::VolPath(v) => v.li(scene, ray, rng, stats, scratch),
            Integrator::Depth(d) => d.li(scene, ray, stats),
        }
    }
}
