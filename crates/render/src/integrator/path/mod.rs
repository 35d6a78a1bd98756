//! Mitsuba `path`: unidirectional path tracing with next-event estimation
//! and multiple importance sampling (power heuristic) of light and BSDF
//! samples, and Russian roulette. Its sampling decisions follow Mitsuba 3's
//! `path.cpp`, so the same scene converges to the same image.
//!
//! | parameter     | type    | default |
//! |---------------|---------|---------|
//! | max_depth     | integer | -1 (unbounded); 1 = emitters seen directly, 2 = direct light |
//! | rr_depth      | integer | 5 (depth at which Russian roulette starts) |
//! | hide_emitters | boolean | false (camera rays pass through emitters; environment black) |
//! | mis           | boolean | true: power heuristic; false: the lecture's split, emitted light only through light samples, reflected light only through BSDF samples |
//! | throughput_threshold | float | 0 (off): stop when max(β) falls below it; biased |
//! | guiding       | boolean | false: path guiding ([`crate::guiding`]), learnt in the first passes |
//! | guiding_budget | float  | 0.25: the share of the samples (under `--time`, of the time) whose passes train the guide (their samples are kept) |
//! | guiding_bsdf_fraction | float | 0.85: at a guided vertex, the probability of drawing from the BSDF rather than the guide |
//! | guiding_min_roughness | float | 0.3: a vertex whose only non-delta lobe is a microfacet lobe of roughness α below this (the lesser of α_u, α_v) is not guided: a guide's quadtree cannot follow so narrow a lobe, and its draws there only add variance |
//! | guiding_roulette | boolean | true: after the guide's training, Russian roulette by the share of its pixel a path is expected to bring ([`crate::guiding::roulette`]) where the guide knows the radiance ahead; false: by throughput, as without guiding |
//! | guiding_spatial_threshold | float | 12000: c, a spatial leaf of the guide splits once a training pass of 2^k spp gives it more than c·√(2^k) records (Müller et al.'s c); lower: finer space, fewer records per leaf |
//! | caustics      | boolean | true in scene files (false in `PathIntegrator::default()`): caustics (light, delta bounces, then non-delta vertices, the last seen by the camera) of area lights and of concentrated sources at infinity (a sun, not a sky) carried by light paths connected to the camera, which camera paths then leave out (`path/caustics.rs`); off for cameras other than perspective and thin lens, with `hide_emitters`, and nested in `aov`/`moment` |
//! | caustic_paths | float   | 1/32: light paths per camera sample for the caustics, in (0, 1] |
//! | caustic_bounces | integer | -1 (as many as `max_depth` allows): non-delta bounces a caustics' light path may take before the vertex the camera sees, -1 or 0 to 64; 0: caustics seen directly only |
//! | light_candidates | integer | light samples drawn per vertex to resample the one whose shadow ray is traced (resampled importance sampling, see below), 1 to 64; by default 4 in scenes of at least 8 lights, else 1 |
//!
//! **Guided vertices.** With a trained guide, a vertex with a non-delta lobe
//! draws its direction from the BSDF with probability α
//! (`guiding_bsdf_fraction`), else from the guide's quadtree at the
//! point (folded onto wo's side of the surface when the BSDF only reflects,
//! [`GuideDensity`]), and weighs it by f cos θ / (α p_bsdf + (1 − α) p_guide) (one-sample
//! MIS, balance heuristic; Müller et al. 2017, sec. 4). That mixed density
//! replaces the BSDF's in both MIS weights against light sampling, so
//! every estimate stays unbiased: the mixture is positive wherever the
//! BSDF's density is. A delta lobe drawn by the BSDF keeps its weight over α.
//!
//! **Resampled light selection.** With `light_candidates` M > 1, a vertex
//! draws M light samples as it would draw one, picks one with probability
//! proportional to its unshadowed contribution over its density, and traces
//! only that one's shadow ray (resampled importance sampling, Talbot et al.
//! 2005). Its MIS weights keep one candidate's density, as emitters hit by
//! BSDF samples do. In the stream, vertices whose candidates are all area
//! lights on meshes or spheres run in lanes (up to
//! [`MAX_LANE_CANDIDATES`] candidates); the others run the scalar code.

mod caustics;
mod lanes;

pub use caustics::CausticTargets;
pub use lanes::{LaneBatch, LaneBins, LaneKind, LaneOutcomes, LaneSetup, MAX_LANE_CANDIDATES};

use super::{RayStats, Termination};
use crate::accel::Hit;
use crate::bsdf::{Bsdf, BsdfSample};
use crate::geometry::{Ray, SurfaceInteraction};
use crate::guiding::{Guide, GuideDensity, GuideRecord, SPATIAL_THRESHOLD};
use crate::light::{LightSample, LightSelection};
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::mis::power_heuristic;
use crate::sampling::reservoir::Reservoir;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use glam::Vec3;

/// The `path` integrator's parameters.
#[derive(Debug, Clone)]
pub struct PathIntegrator {
    /// Path length limits and Russian roulette.
    pub term: Termination,
    /// Mitsuba's `hide_emitters`: camera rays pass through area emitters
    /// and see a black environment.
    pub hide_emitters: bool,
    /// Weight light and BSDF samples by the power heuristic; when false,
    /// each kind of sample estimates its own part of the integral.
    pub mis: bool,
    /// Path guiding: how the guide is trained and mixed with the BSDF
    /// (`None`: off). The guide itself is the render's state, passed to
    /// [`Self::li_guided`] pass by pass.
    pub guiding: Option<Guiding>,
    /// How many light samples a vertex draws to resample one from
    /// (see the module notes); 1: the light sample as drawn; 0: chosen by
    /// the scene's light count ([`Self::light_candidates_for`]).
    pub light_candidates: u32,
    /// Caustics seen directly (light, then delta bounces, then one
    /// non-delta vertex seen by the camera) carried by light paths
    /// connected to the camera instead of by camera paths (`path/caustics.rs`).
    pub caustics: bool,
    /// Light paths per camera sample for the caustics, in (0, 1]: each
    /// pixel sample traces its light path with this probability, weighted
    /// by its inverse.
    pub caustic_paths: f32,
    /// How many non-delta bounces a caustics' light path may take between
    /// its first delta chain and the vertex the camera sees (0: caustics
    /// seen directly only; 1: also a caustic's light bounced once, as the
    /// ceiling lit by the floor's caustic; `u32::MAX`: as many as the depth
    /// allows; see `path/caustics.rs`). Values from 0 to 254 and `u32::MAX`
    /// (the camera paths count bounces up to 255).
    pub caustic_bounces: u32,
}

/// The most `light_candidates` a scene may ask for.
pub const MAX_LIGHT_CANDIDATES: u32 = 64;

/// Scenes of at least this many lights resample their light samples by
/// default...
pub const MANY_LIGHTS: usize = 8;
/// ...from this many candidates. Measured at equal time (4 s, 128x128, 2
/// threads) on the 100-light scene: relMSE 9.0e-4 with one candidate, 8.4e-4
/// with 2, 7.0e-4 with 4, 7.4e-4 with 6, 7.9e-4 with 8. With one light,
/// candidates cost more than they gain (the Cornell box: 2.2e-3 → 5.5e-3).
pub const DEFAULT_LIGHT_CANDIDATES: u32 = 4;

/// Whether a `path` loaded from a scene carries caustics by light paths
/// (`PathIntegrator::default()`, Mitsuba's estimator alone, does not).
pub const DEFAULT_CAUSTICS: bool = true;

/// Light paths per camera sample for the caustics by default.
pub const DEFAULT_CAUSTIC_PATHS: f32 = 0.03125;

/// Non-delta bounces a caustics' light path may take by default: as many
/// as the depth allows. Measured at equal time (4 s, 128x128, 2 threads,
/// relMSE against the bench's references, reference floor subtracted), 0 /
/// 2 / unbounded: the Cornell box 8.8e-4 / 3.8e-4 / 2.4e-4, envmap_sun
/// 2.5e-4 / 1.6e-4 / 1.6e-4, glass-caustic 8.9e-4 / 3.1e-4 / 2.9e-4; the
/// material showcase and many_lights within noise.
pub const DEFAULT_CAUSTIC_BOUNCES: u32 = u32::MAX;

/// The `path` integrator's guiding parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guiding {
    /// The share of the samples whose passes train the guide.
    pub budget: f32,
    /// α: the probability that a guided vertex draws from the BSDF, in (0, 1].
    pub bsdf_fraction: f32,
    /// Roulette by expected contribution once trained ([`crate::guiding::roulette`]).
    pub roulette: bool,
    /// c: a spatial leaf splits once a pass gives it more than c·√(2^pass)
    /// records ([`crate::guiding::Guide::update`]).
    pub spatial_threshold: f32,
    /// Vertices whose lobe is narrower than this roughness are not guided
    /// ([`crate::bsdf::Bsdf::narrower_than`]).
    pub min_roughness: f32,
}

impl Default for Guiding {
    fn default() -> Self {
        Guiding {
            budget: 0.25,
            // At equal time (4 s, 2 seeds) 0.85 beat 0.5 and 0.7 on each of the
            // six efficiency scenes, and 0.95 on the three tried.
            bsdf_fraction: 0.85,
            roulette: true,
            spatial_threshold: SPATIAL_THRESHOLD as f32,
            min_roughness: 0.3,
        }
    }
}

impl Default for PathIntegrator {
    fn default() -> Self {
        PathIntegrator {
            term: Termination::default(),
            hide_emitters: false,
            mis: true,
            guiding: None,
            light_candidates: 0,
            caustics: false,
            caustic_paths: DEFAULT_CAUSTIC_PATHS,
            caustic_bounces: DEFAULT_CAUSTIC_BOUNCES,
        }
    }
}

/// A guided vertex's direction, as [`GuideRecord`] needs it once the
/// path's radiance is known.
#[derive(Debug, Clone, Copy)]
pub struct Sampled {
    /// The vertex.
    pub p: Vec3,
    /// The direction drawn (world).
    pub d: Vec3,
    /// The density it was drawn with.
    pub pdf: f32,
}

/// A path between two vertices: all that [`PathIntegrator::li`] keeps from
/// one vertex to the next. A stream of paths (the render's stream module) holds many
/// of these and traces their rays together; [`PathIntegrator::li`] walks one.
#[derive(Debug, Clone, Copy)]
pub struct PathState {
    /// The ray whose closest hit the next vertex needs.
    pub ray: Ray,
    /// Radiance gathered so far.
    l: Spectrum,
    /// Throughput β.
    beta: Spectrum,
    /// Product of relative IORs crossed (for Russian roulette).
    eta: f32,
    /// Segments completed.
    depth: u32,
    /// The previous vertex, for MIS of emitters hit by BSDF sampling.
    prev_p: Vec3,
    prev_n: Vec3,
    prev_bsdf_pdf: f32,
    prev_delta: bool,
    /// The light sample's contribution, added if its shadow ray is unblocked.
    pending: Spectrum,
    /// Its pixel's value as the guide's training saw it, for roulette by
    /// expected contribution (0: roulette by throughput).
    target: f32,
    /// The guide's mean record at the last guided vertex (Φ, see
    /// [`crate::guiding::dtree::DTree::radiance`]).
    flux: f32,
    /// Whether the first surface vertex drew a non-delta direction and
    /// every delta bounce since was on a shape whose caustics light paths
    /// carry: emission found now after a delta bounce is a caustic's when
    /// `smooth` is at most `caustic_bounces`, and light paths carry it when
    /// `caustics` is on (`path/caustics.rs`).
    caustic: bool,
    /// Non-delta bounces after the first surface vertex's (saturating).
    smooth: u8,
    /// Whether the vertex now being shaded is on a shape whose delta
    /// bounces light paths carry ([`Scene::carries_caustics`]).
    on_carrier: bool,
}

impl PathState {
    /// A path leaving the camera along `camera_ray` (what
    /// [`PathIntegrator::start`] returns when `max_depth` is not 0).
    #[inline(always)]
    pub fn camera(camera_ray: &Ray) -> PathState {
        PathState {
            ray: *camera_ray,
            l: Spectrum::ZERO,
            beta: Spectrum::ONE,
            eta: 1.0,
            depth: 0,
            prev_p: camera_ray.o,
            prev_n: Vec3::ZERO,
            prev_bsdf_pdf: 1.0,
            prev_delta: true,
            pending: Spectrum::ZERO,
            target: 0.0,
            flux: 0.0,
            caustic: false,
            smooth: 0,
            on_carrier: false,
        }
    }

    /// Points a path made by [`Self::camera`] (with any ray) along
    /// `camera_ray`: the state `camera(camera_ray)` gives, writing only the
    /// fields the ray sets.
    #[inline(always)]
    pub fn aim(&mut self, camera_ray: &Ray) {
        self.ray = *camera_ray;
        self.prev_p = camera_ray.o;
    }

    /// Sets its pixel's value as the guide's training saw it
    /// ([`PathIntegrator::roulette_target`]).
    #[inline]
    pub fn set_target(&mut self, target: f32) {
        self.target = target;
    }

    /// The radiance gathered so far (all of it once the path has ended).
    #[inline]
    pub fn radiance(&self) -> Spectrum {
        self.l
    }

    /// The throughput β.
    #[inline]
    pub fn throughput(&self) -> Spectrum {
        self.beta
    }

    /// Whether the last bounce was specular (or the path is a camera ray).
    #[inline]
    pub fn prev_delta(&self) -> bool {
        self.prev_delta
    }

    /// The last vertex's position and normal (the receiver whose light
    /// sampling an escape is weighted against).
    #[inline]
    pub fn prev_vertex(&self) -> (Vec3, Vec3) {
        (self.prev_p, self.prev_n)
    }

    /// The verdict on the shadow ray of the last vertex ([`Vertex::shadow`]):
    /// the light sample counts if it was not blocked. Called before the
    /// next vertex, so radiance is summed in the same order as in one loop.
    #[inline]
    pub fn shadow_done(&mut self, occluded: bool) {
        if !occluded {
            self.l += self.pending;
        }
    }

    /// After a bounce drawn from a `delta` lobe or not (before `depth`
    /// counts it) at a vertex on a carrier (`on_carrier`) or not: whether
    /// the path may now be a caustic's (see `caustic`): its first vertex
    /// drew a non-delta direction, and every delta bounce since was on a
    /// carrier; and how many non-delta bounces followed the first.
    #[inline(always)]
    fn bounced(&mut self, delta: bool) {
        if self.depth == 0 {
            self.caustic = !delta;
            self.smooth = 0;
        } else if delta {
            self.caustic &= self.on_carrier;
        } else {
            self.smooth = self.smooth.saturating_add(1);
        }
    }
}

/// What one vertex asks of whoever traces the rays.
#[derive(Debug, Clone, Copy)]
pub struct Vertex {
    /// The shadow ray of the light sample, whose verdict goes to
    /// [`PathState::shadow_done`].
    pub shadow: Option<Ray>,
    /// Whether the path goes on: then the closest hit of `PathState::ray`
    /// is the next vertex's input.
    pub go_on: bool,
    /// The non-delta direction drawn for the next segment, for the guide's
    /// training (`None` after a delta lobe, or when nothing was drawn).
    pub sampled: Option<Sampled>,
}

/// A light sample with the BSDF's side of it, as the vertex weighs it.
#[derive(Debug, Clone, Copy)]
struct LitSample {
    ls: LightSample,
    /// f cos θ towards the light.
    f: Spectrum,
    /// The BSDF's density of `ls.wi` (0 without MIS or for a delta light).
    bsdf_pdf: f32,
    /// The resampling factor (Σ w_i / M) / w_y (1 for a single candidate).
    scale: f32,
}

impl Vertex {
    const DONE: Vertex = Vertex { shadow: None, go_on: false, sampled: None };
}

/// Candidate `i` of `m`'s numbers (see [`PathIntegrator::resample_light`]):
/// the light's pick stratified, (u_sel + i/M) mod 1, and its point spread
/// by the R2 sequence's offsets (Roberts 2018), (u_light + i·(g₁, g₂)) mod 1.
#[inline(always)]
fn candidate_numbers(u_sel: f32, u_light: glam::Vec2, i: u32, m: u32) -> (f32, glam::Vec2) {
    let (u, ux, uy) = candidate_numbers_lanes::<f32>(u_sel, (u_light.x, u_light.y), i, m);
    (u, glam::Vec2::new(ux, uy))
}

/// The R2 sequence's offsets of [`candidate_numbers`].
const R2: glam::Vec2 = glam::Vec2::new(0.754_877_7, 0.569_840_3);

/// [`candidate_numbers`] in lanes (it is the one-lane instance); the sums
/// are not negative, so `x - ⌊x⌋` is the fractional part.
#[inline(always)]
fn candidate_numbers_lanes<F: crate::simd::Float>(u_sel: F, u_light: (F, F), i: u32, m: u32) -> (F, F, F) {
    let fract = |x: F| x - x.floor();
    let r = i as f32 * R2;
    (fract(u_sel + F::splat(i as f32 / m as f32)), fract(u_light.0 + F::splat(r.x)), fract(u_light.1 + F::splat(r.y)))
}

impl PathIntegrator {
    /// Estimates L(x, -d) = Le + ∫ f Li cos dω (the rendering equation,
    /// Kajiya 1986) with one light sample and one BSDF sample per vertex,
    /// each MIS-weighted against the other (Veach 1997, eq. 9.13): the
    /// path's vertices one after the other, each ray traced alone.
    pub fn li(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        self.li_guided(scene, camera_ray, rng, stats, scratch, None, None, 0.0)
    }

    /// [`Self::li`] guided by `guide` (see the module notes) and, with
    /// `records`, adding a training record for each non-delta direction
    /// drawn: the radiance the rest of the path brought back along it,
    /// over the throughput, over the density it was drawn with.
    #[allow(clippy::too_many_arguments)]
    pub fn li_guided(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
        guide: Option<&Guide>,
        records: Option<&mut Vec<GuideRecord>>,
        target: f32,
    ) -> Spectrum {
        let Some(mut st) = self.start(camera_ray) else { return Spectrum::ZERO };
        st.set_target(target);
        // Per drawn direction: it, the throughput after it, the radiance before it.
        let mut drawn: Vec<(Sampled, Spectrum, Spectrum)> = Vec::new();
        loop {
            stats.rays += 1;
            let hit = scene.intersect(&st.ray);
            let v = self.vertex_guided(scene, &mut st, hit, rng, scratch, guide);
            if let Some(r) = v.shadow {
                stats.shadow_rays += 1;
                st.shadow_done(scene.occluded_ray(&r));
            }
            if let (Some(s), Some(_)) = (v.sampled, records.as_ref()) {
                // Ended by roulette: the rest brings nothing (β = 0).
                drawn.push((s, if v.go_on { st.beta } else { Spectrum::ZERO }, st.l));
            }
            if !v.go_on {
                break;
            }
        }
        if let Some(records) = records {
            for (s, beta, before) in drawn {
                records.extend(Self::record(st.l, s, beta, before));
            }
        }
        st.radiance()
    }

    /// The training record of direction `s` drawn on a path that gathered
    /// `total` in all and `before` until then (its light sample included),
    /// with throughput `beta` after it (0 where roulette ended the path
    /// there: the rest brings nothing): L_i = (radiance after) / β per
    /// channel, averaged over the channels β carries.
    pub fn record(total: Spectrum, s: Sampled, beta: Spectrum, before: Spectrum) -> Option<GuideRecord> {
        let after = total - before;
        let (mut sum, mut n) = (0.0, 0);
        for c in 0..3 {
            if beta[c] > 0.0 {
                sum += after[c] / beta[c];
                n += 1;
            }
        }
        let radiance = if n > 0 { sum / n as f32 } else { 0.0 };
        GuideRecord::new(s.p, s.d, radiance, s.pdf)
    }

    /// A path leaving the camera along `camera_ray`, or `None` when
    /// `max_depth` is 0 (the estimate is then 0).
    pub fn start(&self, camera_ray: &Ray) -> Option<PathState> {
        (self.term.max_depth > 0).then(|| PathState::camera(camera_ray))
    }

    /// One vertex at `hit`, the closest hit of `st.ray`: emission there
    /// (MIS-weighted against light sampling at the previous vertex), a light
    /// sample (its shadow ray returned), a BSDF sample for the next segment
    /// and Russian roulette. With `hide_emitters`, a camera ray that hits an
    /// emitter is continued behind it first (as the other integrators' `camera_hit`).
    #[inline]
    pub fn vertex(
        &self,
        scene: &Scene,
        st: &mut PathState,
        hit: Option<SurfaceInteraction>,
        rng: &mut SampleStream,
        scratch: &Scratch,
    ) -> Vertex {
        self.vertex_guided(scene, st, hit, rng, scratch, None)
    }

    /// [`Self::vertex`], its direction drawn from the mix of the BSDF and
    /// `guide` once the guide is trained (see the module notes).
    #[inline(always)]
    pub fn vertex_guided(
        &self,
        scene: &Scene,
        st: &mut PathState,
        hit: Option<SurfaceInteraction>,
        rng: &mut SampleStream,
        scratch: &Scratch,
        guide: Option<&Guide>,
    ) -> Vertex {
        let Some(mut si) = hit else {
            // Escaped: environment emission, MIS-weighted against light sampling.
            if st.prev_delta {
                // Camera ray or specular bounce: weight 1, no density needed.
                if self.delta_miss_seen(st) {
                    Self::add_delta_miss(st, scene.environment_radiance(st.ray.d));
                } else if self.carried_by_light_paths(st) {
                    // A caustic: light paths carry the concentrated part.
                    Self::add_delta_miss(st, scene.environment_radiance_left_to_camera(st.ray.d));
                }
            } else {
                let (le, env_pdf) = scene.environment(st.prev_p, st.prev_n, st.ray.d);
                self.add_mis_miss(st, le, env_pdf);
            }
            return Vertex::DONE;
        };
        if st.depth == 0 && self.hide_emitters && scene.shape_info[si.shape as usize].light.is_some() {
            st.ray = scene.spawn_ray(&si, st.ray.d);
            return Vertex { shadow: None, go_on: true, sampled: None };
        }

        self.add_emitted(scene, st, &si);
        if st.depth + 1 >= self.term.max_depth {
            return Vertex::DONE;
        }
        let bsdf = scene.bsdf(&mut si, scratch);
        let wo = si.to_local(si.wo);
        // The guide's density here, where a lobe is not delta.
        let alpha = self.guide_bsdf_fraction();
        let guided = bsdf.has_smooth() && !bsdf.narrower_than(self.guide_min_roughness());
        let guide = guide.filter(|g| g.trained() && guided).map(|g| GuideDensity {
            tree: g.at(si.p),
            fold: bsdf.reflects_only().then(|| si.to_world(Vec3::new(0.0, 0.0, if wo.z < 0.0 { -1.0 } else { 1.0 }))),
        });

        // Light sampling (next-event estimation).
        let mut shadow = None;
        let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
        if bsdf.has_smooth() {
            let m = self.light_candidates_for(scene.lights.len());
            let lit = if m > 1 {
                let u_pick = rng.next_1d();
                self.resample_light(scene, &si, &bsdf, wo, m, (u_sel, u_light, u_pick))
            } else {
                scene.sample_light(si.p, si.n, u_sel, u_light).and_then(|ls| self.light_value(&si, &bsdf, wo, ls))
            };
            if let Some(LitSample { ls, f, bsdf_pdf, scale }) = lit {
                let bsdf_pdf = match guide {
                    Some(g) => alpha * bsdf_pdf + (1.0 - alpha) * g.pdf(ls.wi),
                    None => bsdf_pdf,
                };
                let w = if self.mis && !ls.delta { power_heuristic(ls.pdf, bsdf_pdf) } else { 1.0 };
                st.pending = st.beta * f * ls.li * (w / ls.pdf * scale);
                shadow = Some(scene.shadow_ray(&si, ls.wi, ls.dist));
            }
        }

        // BSDF sampling for the next segment.
        let u = rng.next_1d();
        let u2 = rng.next_2d();
        let sample = match guide {
            Some(g) => {
                st.flux = g.tree.flux();
                Self::sample_guided(&bsdf, &g, alpha, &si, wo, u, u2)
            }
            None => bsdf.sample(wo, u, u2).map(|bs| (bs, 0.0)),
        };
        let Some((bs, guide_pdf)) = sample else { return Vertex { shadow, go_on: false, sampled: None } };
        st.beta *= bs.weight;
        st.eta *= bs.eta;
        let wi = si.to_world(bs.wi);
        let sampled = (!bs.delta).then_some(Sampled { p: si.p, d: wi, pdf: bs.pdf });
        st.prev_p = si.p;
        st.prev_n = si.n;
        st.prev_bsdf_pdf = bs.pdf;
        st.prev_delta = bs.delta;
        st.ray = scene.spawn_ray(&si, wi);
        st.on_carrier = scene.carries_caustics(si.shape);
        st.bounced(bs.delta);
        st.depth += 1;
        Vertex { shadow, go_on: self.roulette(st, rng, guide_pdf), sampled }
    }

    /// The BSDF's side of light sample `ls` at `si`: f cos θ and, with MIS,
    /// the BSDF's density of its direction; `None` where f cos θ is zero.
    #[inline(always)]
    fn light_value(&self, si: &SurfaceInteraction, bsdf: &Bsdf, wo: Vec3, ls: LightSample) -> Option<LitSample> {
        let wi = si.to_local(ls.wi);
        // With MIS, value and pdf in one BSDF dispatch.
        let (f, bsdf_pdf) = if self.mis && !ls.delta { bsdf.eval_pdf(wo, wi) } else { (bsdf.eval(wo, wi), 0.0) };
        let f = f * wi.z.abs();
        (f != Spectrum::ZERO).then_some(LitSample { ls, f, bsdf_pdf, scale: 1.0 })
    }

    /// Resampled importance sampling of the light (Talbot et al. 2005,
    /// eq. 3): `m` = M candidates x_i drawn as
    /// [`Scene::sample_light`] draws one (density p), one of them y picked
    /// with probability ∝ w_i = p̂(x_i) / p(x_i), where the target p̂ is the
    /// unshadowed contribution |f cos θ L_e| (the sum of its channels); the
    /// estimate f(y) / p(y) is then scaled by (Σ w_i / M) / w_y.
    ///
    /// Unbiased for any candidates whose marginals are p (only linearity is
    /// used), so they share the vertex's numbers: candidate i takes
    /// (u_sel + i/M, u_light + i·(g₁, g₂)) mod 1, stratified in the light's
    /// pick and spread by the R2 sequence's offsets (Roberts 2018) over its
    /// point, and `u.2` picks among them. The MIS weight against BSDF
    /// sampling keeps the density p of one candidate: both strategies use
    /// the same function in their weights, so the weights still sum to 1.
    fn resample_light(
        &self,
        scene: &Scene,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        wo: Vec3,
        m: u32,
        u: (f32, glam::Vec2, f32),
    ) -> Option<LitSample> {
        let (u_sel, u_light, u_pick) = u;
        let mut r = Reservoir::new(u_pick);
        for i in 0..m {
            let (u_i, u2_i) = candidate_numbers(u_sel, u_light, i, m);
            let Some(ls) = scene.sample_light(si.p, si.n, u_i, u2_i) else { continue };
            let Some(c) = self.light_value(si, bsdf, wo, ls) else { continue };
            let contribution = c.f * c.ls.li;
            let target = contribution[0].abs() + contribution[1].abs() + contribution[2].abs();
            r.add(c, target / c.ls.pdf);
        }
        let (mut c, w) = r.picked()?;
        c.scale = r.weight_sum() / m as f32 / w;
        Some(c)
    }

    /// The next direction drawn from the BSDF with probability `alpha`
    /// (`u` below it, rescaled, picks the lobe), else from the guide `d`
    /// with `u2`; a non-delta direction weighted by the mixed density. With
    /// it, the guide's density of the direction (0 for a delta one).
    #[inline(never)]
    fn sample_guided(
        bsdf: &Bsdf,
        g: &GuideDensity,
        alpha: f32,
        si: &SurfaceInteraction,
        wo: Vec3,
        u: f32,
        u2: glam::Vec2,
    ) -> Option<(BsdfSample, f32)> {
        let (wi, eta, pdf_guide) = if u < alpha {
            let bs = bsdf.sample(wo, u / alpha, u2)?;
            if bs.delta {
                // The guide never draws it: weight over the probability of asking the BSDF.
                return Some((BsdfSample { pdf: bs.pdf * alpha, weight: bs.weight / alpha, ..bs }, 0.0));
            }
            (bs.wi, bs.eta, g.pdf(si.to_world(bs.wi)))
        } else {
            // The relative IOR is unknown here; 1 only changes Russian roulette's odds.
            let (d, pdf) = g.sample(u2);
            (si.to_local(d), 1.0, pdf)
        };
        let (f, pdf_bsdf) = bsdf.eval_pdf(wo, wi);
        let pdf = alpha * pdf_bsdf + (1.0 - alpha) * pdf_guide;
        let f = f * wi.z.abs();
        if pdf.is_nan() || pdf <= 0.0 || f == Spectrum::ZERO {
            return None;
        }
        Some((BsdfSample { wi, pdf, weight: f / pdf, delta: false, null: false, eta }, pdf_guide))
    }

    /// The light candidates a vertex draws in a scene of `lights` lights:
    /// `light_candidates`, or where that is 0, [`DEFAULT_LIGHT_CANDIDATES`]
    /// from [`MANY_LIGHTS`] lights on and 1 below.
    #[inline]
    pub fn light_candidates_for(&self, lights: usize) -> u32 {
        match self.light_candidates {
            0 if lights >= MANY_LIGHTS => DEFAULT_LIGHT_CANDIDATES,
            0 => 1,
            m => m,
        }
    }

    /// Its sampling parameters, as `penumbra info` and the EXR metadata
    /// record them, for a scene of `lights` lights picked by `selection`.
    pub fn summary(&self, lights: usize, selection: LightSelection) -> String {
        let guiding = match self.guiding {
            Some(g) => format!(
                "guiding=true (budget {}, bsdf_fraction {}, roulette {}, spatial_threshold {}, min_roughness {})",
                g.budget,
                g.bsdf_fraction,
                if g.roulette { "by expected contribution" } else { "by throughput" },
                g.spatial_threshold,
                g.min_roughness
            ),
            None => "guiding=false".into(),
        };
        let caustics = match self.caustics {
            true => match self.caustic_bounces {
                u32::MAX => format!("caustics=true (caustic_paths {}, caustic_bounces -1)", self.caustic_paths),
                n => format!("caustics=true (caustic_paths {}, caustic_bounces {n})", self.caustic_paths),
            },
            false => "caustics=false".into(),
        };
        let depth = |d: u32| if d == u32::MAX { "-1".to_string() } else { d.to_string() };
        format!(
            "max_depth={}, rr_depth={}, mis={}, light_selection={}, light_candidates={}, {caustics}, {guiding}",
            depth(self.term.max_depth),
            self.term.rr_depth,
            self.mis,
            selection.name(),
            self.light_candidates_for(lights)
        )
    }

    /// α: at a guided vertex, the probability of drawing from the BSDF
    /// rather than the guide (1 without guiding).
    #[inline]
    fn guide_bsdf_fraction(&self) -> f32 {
        self.guiding.map_or(1.0, |g| g.bsdf_fraction)
    }

    /// The roughness below which a lobe is not guided (0 without guiding).
    #[inline]
    fn guide_min_roughness(&self) -> f32 {
        self.guiding.map_or(0.0, |g| g.min_roughness)
    }

    /// The value of pixel `global` that roulette by expected contribution
    /// compares with: the guide's image, 0 (roulette by throughput)
    /// without a guide or with `guiding_roulette` off.
    #[inline]
    pub fn roulette_target(&self, guide: Option<&Guide>, global: (u32, u32)) -> f32 {
        match (self.guiding, guide) {
            (Some(g), Some(guide)) if g.roulette => guide.pixel_estimate(global),
            _ => 0.0,
        }
    }

    /// Russian roulette after a bounce: whether the path goes on (its
    /// throughput divided by the survival probability). Where the bounce
    /// was guided (`guide_pdf`, the guide's density of the direction, > 0)
    /// and the path has a target, by the share of it the path is expected
    /// to bring, β̄ · Φ · p_guide / target ([`crate::guiding::roulette`]);
    /// else by throughput.
    #[inline]
    fn roulette(&self, st: &mut PathState, rng: &mut SampleStream, guide_pdf: f32) -> bool {
        let expected = (guide_pdf > 0.0 && st.flux > 0.0 && st.target > 0.0)
            .then(|| (st.beta[0] + st.beta[1] + st.beta[2]) * (1.0 / 3.0) * st.flux * guide_pdf / st.target);
        match self.term.survive_expected(st.beta, st.eta, st.depth, expected, rng) {
            Some(q) => {
                st.beta /= q;
                true
            }
            None => false,
        }
    }

    /// Whether a path whose ray escapes sees the environment with weight 1:
    /// its last vertex was the camera or a specular bounce, and the
    /// environment is not hidden from camera rays.
    #[inline]
    pub fn delta_miss_seen(&self, st: &PathState) -> bool {
        st.prev_delta && !(st.depth == 0 && self.hide_emitters) && !self.carried_by_light_paths(st)
    }

    /// Whether emission found now by a path whose last bounce was delta
    /// belongs to the light paths (`path/caustics.rs`): with `caustics` on, the
    /// path's first surface vertex drew a non-delta direction, every delta
    /// bounce since was on a carrier, and at most `caustic_bounces` were not
    /// delta.
    #[inline(always)]
    fn carried_by_light_paths(&self, st: &PathState) -> bool {
        self.caustics && st.caustic && u32::from(st.smooth) <= self.caustic_bounces
    }

    /// Whether the vertex at `hit` adds nothing and ends the path, so that a
    /// stream may end it without [`Self::vertex`]: the last vertex (depth + 1
    /// = `max_depth`, where `vertex` adds only emission) on a shape that
    /// emits nothing, outside instances.
    #[inline]
    pub fn ends_dark(&self, scene: &Scene, st: &PathState, hit: &Hit) -> bool {
        st.depth + 1 >= self.term.max_depth
            && hit.instance == Hit::NOT_INSTANCED
            && scene.shape_info[hit.shape as usize].light.is_none()
    }

    /// The escape of a path for which [`Self::delta_miss_seen`] holds, with
    /// `le` = [`Scene::environment_radiance`] of its ray: all of
    /// [`Self::vertex`] for that path (it ends), so a stream may evaluate
    /// `le` for many paths at once.
    #[inline]
    pub fn add_delta_miss(st: &mut PathState, le: Spectrum) {
        st.l += st.beta * le;
    }

    /// The escape of a path whose last bounce was not specular, with (`le`,
    /// `env_pdf`) = [`Scene::environment`] of its ray from its last vertex
    /// ([`PathState::prev_vertex`]): the environment's radiance weighted
    /// against light sampling there. All of [`Self::vertex`] for that path.
    #[inline]
    pub fn add_mis_miss(&self, st: &mut PathState, le: Spectrum, env_pdf: f32) {
        if le != Spectrum::ZERO {
            st.l += st.beta * le * self.bsdf_weight(st.prev_bsdf_pdf, env_pdf);
        }
    }

    /// Emission at the hit `si` added to the path's radiance,
    /// MIS-weighted against light sampling at the previous vertex.
    #[inline]
    fn add_emitted(&self, scene: &Scene, st: &mut PathState, si: &SurfaceInteraction) {
        let le = scene.emitted(si);
        if le != Spectrum::ZERO {
            let w = if st.prev_delta {
                if self.carried_by_light_paths(st) {
                    return;
                }
                1.0
            } else {
                self.bsdf_weight(st.prev_bsdf_pdf, scene.light_pdf(st.prev_p, st.prev_n, si))
            };
            st.l += st.beta * le * w;
        }
    }

    /// MIS weight of emission found by BSDF sampling after a non-delta
    /// bounce (after a delta one it is 1, and callers skip this). Without
    /// MIS, that emission belongs to light sampling alone (weight 0).
    #[inline]
    fn bsdf_weight(&self, bsdf_pdf: f32, light_pdf: f32) -> f32 {
        if self.mis {
            power_heuristic(bsdf_pdf, light_pdf)
        } else {
            0.0
        }
    }
}
