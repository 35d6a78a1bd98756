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

use super::{camera_hit, RayStats, Termination};
use crate::geometry::Ray;
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::mis::power_heuristic;
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
}

impl Default for PathIntegrator {
    fn default() -> Self {
        PathIntegrator { term: Termination::default(), hide_emitters: false, mis: true }
    }
}

impl PathIntegrator {
    /// Estimates L(x, -d) = Le + ∫ f Li cos dω (the rendering equation,
    /// Kajiya 1986) with one light sample and one BSDF sample per vertex,
    /// each MIS-weighted against the other (Veach 1997, eq. 9.13).
    pub fn li(
        &self,
        scene: &Scene,
        camera_ray: &Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        if self.term.max_depth == 0 {
            return Spectrum::ZERO;
        }
        let mut l = Spectrum::ZERO;
        let mut beta = Spectrum::ONE;
        let mut eta = 1.0f32;
        let mut ray = *camera_ray;
        let mut depth = 0u32;
        // The previous vertex, for MIS of emitters hit by BSDF sampling.
        let mut prev_p = ray.o;
        let mut prev_n = Vec3::ZERO;
        let mut prev_bsdf_pdf = 1.0f32;
        let mut prev_delta = true;

        loop {
            let hit = if depth == 0 {
                camera_hit(scene, &ray, self.hide_emitters, stats)
            } else {
                stats.rays += 1;
                scene.intersect(&ray)
            };

            let Some(mut si) = hit else {
                // Escaped: environment emission, MIS-weighted against light sampling.
                if prev_delta {
                    // Camera ray or specular bounce: weight 1, no density needed.
                    if !(depth == 0 && self.hide_emitters) {
                        l += beta * scene.environment_radiance(ray.d);
                    }
                } else {
                    let (le, env_pdf) = scene.environment(prev_p, prev_n, ray.d);
                    if le != Spectrum::ZERO {
                        l += beta * le * self.bsdf_weight(prev_bsdf_pdf, env_pdf);
                    }
                }
                break;
            };

            // Emission at the hit, MIS-weighted against light sampling at the previous vertex.
            let le = scene.emitted(&si);
            if le != Spectrum::ZERO {
                let w = if prev_delta {
                    1.0
                } else {
                    self.bsdf_weight(prev_bsdf_pdf, scene.light_pdf(prev_p, prev_n, &si))
                };
                l += beta * le * w;
            }

            if depth + 1 >= self.term.max_depth {
                break;
            }
            let bsdf = scene.bsdf(&mut si, scratch);
            let wo = si.to_local(si.wo);

            // Light sampling (next-event estimation).
            let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
            if bsdf.has_smooth() {
                if let Some(ls) = scene.sample_light(si.p, si.n, u_sel, u_light) {
                    let wi = si.to_local(ls.wi);
                    let mis = self.mis && !ls.delta;
                    // With MIS, value and pdf in one BSDF dispatch.
                    let (f, bsdf_pdf) = if mis { bsdf.eval_pdf(wo, wi) } else { (bsdf.eval(wo, wi), 0.0) };
                    let f = f * wi.z.abs();
                    if f != Spectrum::ZERO {
                        stats.shadow_rays += 1;
                        if !scene.occluded(&si, ls.wi, ls.dist) {
                            let w = if mis { power_heuristic(ls.pdf, bsdf_pdf) } else { 1.0 };
                            l += beta * f * ls.li * (w / ls.pdf);
                        }
                    }
                }
            }

            // BSDF sampling for the next segment.
            let u = rng.next_1d();
            let u2 = rng.next_2d();
            let Some(bs) = bsdf.sample(wo, u, u2) else { break };
            beta *= bs.weight;
            eta *= bs.eta;
            let wi = si.to_world(bs.wi);
            prev_p = si.p;
            prev_n = si.n;
            prev_bsdf_pdf = bs.pdf;
            prev_delta = bs.delta;
            ray = scene.spawn_ray(&si, wi);
            depth += 1;

            match self.term.survive(beta, eta, depth, rng) {
                Some(q) => beta /= q,
                None => break,
            }
        }
        l
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
