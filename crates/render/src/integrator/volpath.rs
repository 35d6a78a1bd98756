//! Mitsuba `volpath` and `volpathmis`: path tracing through participating
//! media. Free-flight sampling picks scattering points in media; at each
//! scattering point (in a medium or on a surface) one light sample, its
//! shadow ray crossing null surfaces and media with their transmittance,
//! and one phase or BSDF sample, MIS-weighted (power heuristic). Surfaces
//! whose BSDF is null (`null`, a mask's cut-out, `thindielectric`'s
//! transmission) are crossed without counting depth, switching media where
//! shapes bound them. Follows Mitsuba 3's `volpath.cpp` (same depth
//! counting, MIS and medium transitions), so the same scene converges to
//! the same image; the free-flight and transmittance estimators are
//! [`crate::medium`]'s (the same expectations, less variance).
//!
//! | parameter     | type    | default |
//! |---------------|---------|---------|
//! | max_depth     | integer | -1 (unbounded); counts surface and medium scattering, not null crossings |
//! | rr_depth      | integer | 5 (depth at which Russian roulette starts) |
//! | hide_emitters | boolean | false (camera rays pass through emitters, seen from vacuum; environment black) |
//!
//! Chromatic media: each path draws its free-flight distances with one
//! hero channel (chosen uniformly, as Mitsuba's `volpath`) and is weighted
//! by the balance heuristic over the three channels' path densities
//! (Mitsuba's `volpathmis`); so `volpath` and `volpathmis`, which take the
//! same parameters, are one estimator here, with `volpathmis`'s variance.

use super::{RayStats, Termination};
use crate::geometry::Ray;
use crate::material::Scratch;
use crate::math::{Spectrum, SHADOW_EPSILON};
use crate::medium::{mean, Flight};
use crate::sampling::mis::power_heuristic;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use glam::Vec3;

/// The `volpath` integrator's parameters.
#[derive(Debug, Clone, Default)]
pub struct VolPathIntegrator {
    /// Path length limits and Russian roulette.
    pub term: Termination,
    /// Mitsuba's `hide_emitters`.
    pub hide_emitters: bool,
}

/// Longest chain of null surfaces a shadow ray crosses (a guard against
/// stacked coplanar null shapes, which would otherwise never end).
const MAX_NULL_CROSSINGS: u32 = 1024;

impl VolPathIntegrator {
    /// Radiance along `camera_ray`, which starts in the camera's medium.
    pub fn li(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        let mut ray = *camera_ray;
        let mut medium = scene.camera_medium;
        let (mut l, mut eta) = (Spectrum::ZERO, 1.0f32);
        // Spectral MIS: the throughput is beta_h / mean(ratio), where
        // beta_h is the value over the hero channel's path density and
        // ratio each channel's path density over the hero's.
        let hero = ((rng.next_1d() * 3.0) as usize).min(2);
        let (mut beta_h, mut ratio) = (Spectrum::ONE, Spectrum::ONE);
        let throughput = |beta_h: Spectrum, ratio: Spectrum| beta_h / mean(ratio);
        let mut depth = 0u32;
        // Emission found by phase or BSDF sampling counts in full after
        // the camera and delta bounces (Mitsuba's `specular_chain`).
        let mut specular_chain = !self.hide_emitters;
        // The last scattering point (normal zero in a medium) and the
        // density of the direction sampled there, for MIS.
        let (mut last_p, mut last_n, mut last_pdf) = (ray.o, Vec3::ZERO, 1.0f32);
        let mut null_crossings = 0u32;
        loop {
            if depth >= self.term.max_depth {
                break;
            }
            stats.rays += 1;
            let hit = scene.intersect(&ray);

            // In a medium: scatter before the surface, or cross to it.
            let in_medium = medium.is_some();
            if let Some(m) = medium {
                let med = &scene.media[m as usize];
                let t_end = hit.as_ref().map_or(f32::INFINITY, |si| si.t);
                match med.sample_flight(&ray, t_end, hero, rng) {
                    Flight::Pass { weight, ratio: r } => {
                        beta_h *= weight;
                        ratio *= r;
                    }
                    Flight::Scatter { t, weight, ratio: r } => {
                        beta_h *= weight;
                        ratio *= r;
                        depth += 1;
                        if depth >= self.term.max_depth || beta_h == Spectrum::ZERO {
                            break;
                        }
                        let beta = throughput(beta_h, ratio);
                        let p = ray.at(t);
                        let wi = -ray.d;
                        specular_chain = !med.sample_emitters;
                        if med.sample_emitters {
                            let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
                            if let Some(ls) = scene.sample_light(p, Vec3::ZERO, u_sel, u_light) {
                                let f = med.phase.eval(p, wi, ls.wi);
                                if f > 0.0 && ls.pdf > 0.0 {
                                    let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, f) };
                                    // Stop short of the light's own surface.
                                    let shadow = Ray::new(p, ls.wi, ls.dist * (1.0 - SHADOW_EPSILON));
                                    let target = p + ls.wi * ls.dist;
                                    let tr = self.transmittance(scene, shadow, target, Some(m), rng, stats, scratch);
                                    l += beta * ls.li * tr * (f * w / ls.pdf);
                                }
                            }
                        }
                        let (wo, pdf) = med.phase.sample(p, wi, rng.next_1d(), rng.next_2d());
                        if pdf <= 0.0 || pdf.is_nan() {
                            break;
                        }
                        (last_p, last_n, last_pdf) = (p, Vec3::ZERO, pdf);
                        ray = Ray::new(p, wo, f32::INFINITY);
                        if !self.survive(&mut beta_h, ratio, eta, depth, rng) {
                            break;
                        }
                        continue;
                    }
                }
            }

            // At the surface (or escaped).
            let beta = throughput(beta_h, ratio);
            let Some(mut si) = hit else {
                if !(depth == 0 && self.hide_emitters) {
                    if specular_chain || depth == 0 {
                        l += beta * scene.environment_radiance(ray.d);
                    } else {
                        let (le, env_pdf) = scene.environment(last_p, last_n, ray.d);
                        if le != Spectrum::ZERO {
                            l += beta * le * power_heuristic(last_pdf, env_pdf);
                        }
                    }
                }
                break;
            };
            let media = scene.shape_media(si.shape);
            if depth == 0 && self.hide_emitters && !in_medium && scene.shape_info[si.shape as usize].light.is_some() {
                // Camera rays see through emitters (the medium changes as
                // for any crossing); as in Mitsuba's volpath, only rays in
                // vacuum do: an emitter reached through a medium is not
                // skipped, and shows as its (unlit) surface.
                if media.is_transition() {
                    medium = media.target(si.n, ray.d);
                }
                ray = scene.spawn_ray(&si, ray.d);
                continue;
            }
            let le = scene.emitted(&si);
            if le != Spectrum::ZERO && !(depth == 0 && self.hide_emitters) {
                let w = if specular_chain || depth == 0 {
                    1.0
                } else {
                    power_heuristic(last_pdf, scene.light_pdf(last_p, last_n, &si))
                };
                l += beta * le * w;
            }

            let bsdf = scene.bsdf(&mut si, scratch);
            let wo = si.to_local(si.wo);
            if depth + 1 < self.term.max_depth && bsdf.has_smooth() {
                let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
                if let Some(ls) = scene.sample_light(si.p, si.n, u_sel, u_light) {
                    let wi = si.to_local(ls.wi);
                    let (f, bsdf_pdf) = bsdf.eval_pdf(wo, wi);
                    let f = f * wi.z.abs();
                    if f != Spectrum::ZERO && ls.pdf > 0.0 {
                        let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, bsdf_pdf) };
                        let m = if media.is_transition() { media.target(si.n, ls.wi) } else { medium };
                        let shadow = scene.shadow_ray(&si, ls.wi, ls.dist);
                        let target = si.p + ls.wi * ls.dist;
                        let tr = self.transmittance(scene, shadow, target, m, rng, stats, scratch);
                        l += beta * f * ls.li * tr * (w / ls.pdf);
                    }
                }
            }

            let Some(bs) = bsdf.sample(wo, rng.next_1d(), rng.next_2d()) else { break };
            beta_h *= bs.weight;
            eta *= bs.eta;
            let wi = si.to_world(bs.wi);
            ray = scene.spawn_ray(&si, wi);
            if media.is_transition() {
                medium = media.target(si.n, wi);
            }
            if bs.null {
                // Crossed, not scattered: depth and the MIS reference stay.
                null_crossings += 1;
                if null_crossings > MAX_NULL_CROSSINGS {
                    break;
                }
                continue;
            }
            null_crossings = 0;
            depth += 1;
            (last_p, last_n, last_pdf) = (si.p, si.n, bs.pdf);
            specular_chain = bs.delta;
            if !self.survive(&mut beta_h, ratio, eta, depth, rng) {
                break;
            }
        }
        l
    }

    /// Russian roulette after a scattering event (Mitsuba's rule, see
    /// [`Termination::survive`]) on the MIS-weighted throughput, which does
    /// not depend on the hero channel; false ends the path.
    #[inline]
    fn survive(&self, beta_h: &mut Spectrum, ratio: Spectrum, eta: f32, depth: u32, rng: &mut SampleStream) -> bool {
        match self.term.survive(*beta_h / mean(ratio), eta, depth, rng) {
            Some(q) => {
                *beta_h /= q;
                true
            }
            None => false,
        }
    }

    /// Transmittance along the shadow ray `ray` (a [`Scene::shadow_ray`]:
    /// unit direction, `t_max` short of the light at `target`, or ∞ for
    /// lights at infinity), starting in `medium`: media by their
    /// estimators, surfaces by their null transmission (zero for opaque
    /// ones), media switched where shapes bound them, each crossed surface
    /// continued by a new shadow ray to `target` (Mitsuba's
    /// `sample_emitter` loop).
    #[allow(clippy::too_many_arguments)]
    fn transmittance(
        &self,
        scene: &Scene,
        mut ray: Ray,
        target: Vec3,
        mut medium: Option<u32>,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        let mut tr = Spectrum::ONE;
        for _ in 0..MAX_NULL_CROSSINGS {
            stats.shadow_rays += 1;
            let hit = scene.intersect(&ray);
            let t_seg = hit.as_ref().map_or(ray.t_max, |si| si.t);
            if let Some(m) = medium {
                tr *= scene.media[m as usize].transmittance(&ray, t_seg, rng);
            }
            let Some(mut si) = hit else { return tr };
            if tr == Spectrum::ZERO {
                return tr;
            }
            let bsdf = scene.bsdf(&mut si, scratch);
            tr *= bsdf.null_transmission(si.to_local(si.wo));
            if tr == Spectrum::ZERO {
                return tr;
            }
            let media = scene.shape_media(si.shape);
            if media.is_transition() {
                medium = media.target(si.n, ray.d);
            }
            let dist = if ray.t_max.is_finite() { (target - si.p).length() } else { f32::INFINITY };
            ray = scene.shadow_ray(&si, ray.d, dist);
        }
        Spectrum::ZERO
    }
}
