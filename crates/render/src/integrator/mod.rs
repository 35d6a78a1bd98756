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
//! | `aov`        | surface quantities of the first hit beside nested integrators' images, as output channels (Mitsuba `aov`) |
//! | `ptracer`    | particle tracing: light paths from the emitters, each vertex connected to the camera and splatted where it lands (Mitsuba `ptracer`; rendered by `RenderJob` itself) |
//! | `moment`     | nested integrators' images and their second moments, as output channels (Mitsuba `moment`) |

pub mod aov;
pub mod aovs;
pub mod bruteforce;
pub mod depth;
pub mod direct;
pub mod moment;
pub mod path;
pub mod ptracer;
pub mod volpath;

pub use aovs::{AovIntegrator, AovType};
pub use bruteforce::{BruteForceIntegrator, HemisphereSampling};
pub use depth::DepthIntegrator;
pub use direct::DirectIntegrator;
pub use moment::MomentIntegrator;
pub use path::{
    Guiding, PathIntegrator, DEFAULT_CAUSTICS, DEFAULT_CAUSTIC_BOUNCES, DEFAULT_CAUSTIC_PATHS,
    DEFAULT_LIGHT_CANDIDATES, MANY_LIGHTS, MAX_LIGHT_CANDIDATES,
};
pub use ptracer::ParticleTracer;
pub use volpath::VolPathIntegrator;

use crate::geometry::Ray;
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use glam::Vec3;

/// A camera ray's differentials (Mitsuba's `RayDifferential`): the rays
/// through the film positions one pixel over in x and in y, already scaled
/// by 1/√spp as Mitsuba's sampling integrators scale them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayDiff {
    /// Origin of the x offset ray.
    pub o_x: Vec3,
    /// Direction of the x offset ray.
    pub d_x: Vec3,
    /// Origin of the y offset ray.
    pub o_y: Vec3,
    /// Direction of the y offset ray.
    pub d_y: Vec3,
}

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
    /// The lanes those packets offered (packets × lane width).
    pub packet_lanes: u64,
    /// The rays those packets held (closest-hit and shadow): over
    /// `packet_lanes`, the lane occupancy.
    pub packet_rays: u64,
    /// Path vertices the stream integrator shaded in lanes
    /// (`PathIntegrator::lane_vertices`); over `rays`, their share.
    pub lane_vertices: u64,
    /// The lanes their batches offered (batches run × lane width): the
    /// vertices above over these lanes is the kernels' lane occupancy.
    pub vertex_lanes: u64,
}

impl RayStats {
    /// Adds another thread's counts.
    pub fn add(&mut self, o: &RayStats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.packets += o.packets;
        self.packet_lanes += o.packet_lanes;
        self.packet_rays += o.packet_rays;
        self.lane_vertices += o.lane_vertices;
        self.vertex_lanes += o.vertex_lanes;
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

    /// [`Self::survive`], or where `expected` is known (the share of its
    /// pixel's value the path is expected to bring) with roulette by
    /// expected contribution ([`roulette`]), at every depth.
    ///
    /// [`roulette`]: crate::guiding::roulette
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn survive_expected(
        &self,
        beta: Spectrum,
        eta: f32,
        depth: u32,
        expected: Option<f32>,
        rng: &mut SampleStream,
    ) -> Option<f32> {
        let Some(r) = expected else { return self.survive(beta, eta, depth, rng) };
        let beta_max = beta.max_element();
        if !(beta_max > 0.0) || beta_max < self.throughput_threshold {
            return None;
        }
        let q = crate::guiding::roulette::survival(r, (beta_max * eta * eta).min(0.95));
        if q >= 1.0 {
            return Some(1.0);
        }
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
    /// `aov`: surface quantities and nested integrators' images.
    Aov(Box<AovIntegrator>),
    /// `moment`: nested integrators' images and second moments.
    Moment(Box<MomentIntegrator>),
    /// `ptracer`: the particle tracer (no estimate per camera ray: the
    /// render driver traces its light paths and splats them).
    PTracer(ParticleTracer),
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
            Integrator::PTracer(_) => Spectrum::ZERO,
            Integrator::Aov(_) | Integrator::Moment(_) => {
                let mut out = vec![0.0; self.channel_names().len()];
                self.sample(scene, ray, None, rng, stats, scratch, &mut out)
            }
        }
    }

    /// The integrator's own output channels (Mitsuba's `aov_names()`),
    /// which the film stores beside the beauty; empty for most.
    pub fn channel_names(&self) -> Vec<String> {
        match self {
            Integrator::Aov(a) => a.channel_names(),
            Integrator::Moment(m) => m.channel_names(),
            _ => Vec::new(),
        }
    }

    /// As [`li`](Self::li), writing the output channels of
    /// [`channel_names`](Self::channel_names) to `out`; `diff`: the camera
    /// ray's differentials, where the camera has them.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        scene: &Scene,
        ray: &Ray,
        diff: Option<&RayDiff>,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
        out: &mut [f32],
    ) -> Spectrum {
        match self {
            Integrator::Aov(a) => a.sample(scene, ray, diff, rng, stats, scratch, out),
            Integrator::Moment(m) => m.sample(scene, ray, diff, rng, stats, scratch, out),
            _ => self.li(scene, ray, rng, stats, scratch),
        }
    }

    /// Whether the camera ray counts as covered (Mitsuba's `valid` mask,
    /// the image's alpha): `aov` reports its first nested integrator's
    /// (0 without one), `moment` its first's.
    pub fn alpha(&self, scene: &Scene, ray: &Ray, stats: &mut RayStats) -> f32 {
        let hide = match self {
            Integrator::Path(p) => p.hide_emitters,
            Integrator::BruteForce(b) => b.hide_emitters,
            Integrator::VolPath(v) => v.hide_emitters,
            Integrator::Direct(_) | Integrator::Depth(_) => true,
            Integrator::PTracer(p) => p.hide_emitters,
            Integrator::Aov(a) => return a.integrators.first().map_or(0.0, |(_, i)| i.alpha(scene, ray, stats)),
            Integrator::Moment(m) => return m.integrators.first().map_or(0.0, |(_, i)| i.alpha(scene, ray, stats)),
        };
        // `depth` and `direct`: any surface; the path tracers look through
        // pass-through surfaces, and count the environment unless hidden.
        let through = !matches!(self, Integrator::Direct(_) | Integrator::Depth(_));
        let mut r = *ray;
        for _ in 0..64 {
            stats.rays += 1;
            let Some(si) = scene.intersect(&r) else { break };
            let m = &scene.materials[scene.shape_info[si.shape as usize].material as usize];
            if !(through && m.has_null_lobe()) {
                return 1.0;
            }
            r = scene.spawn_ray(&si, ray.d);
        }
        if !hide && !scene.env_lights.is_empty() {
            1.0
        } else {
            0.0
        }
    }
}
