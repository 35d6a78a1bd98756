//! `bruteforce`: the hemisphere form of the rendering equation alone. At each
//! hit one direction is sampled and the path goes on; radiance is collected
//! only when a path happens to hit an emitter, weighted by the product of
//! f_r cos θ / p along the path. No light sampling, hence no MIS.
//!
//! Delta lights (point, spot, directional) contribute nothing: a sampled
//! direction hits them with probability zero (the lecture's point). Surfaces
//! whose BSDF is purely specular are continued by BSDF sampling whatever
//! `sampling` says, since a hemisphere sample never hits a Dirac lobe.
//!
//! | parameter     | type    | default |
//! |---------------|---------|---------|
//! | sampling      | string  | cosine: `uniform` (p = 1/2π), `cosine` (p = cos θ/π) or `bsdf` |
//! | max_depth, rr_depth, hide_emitters, throughput_threshold | | as `path` |

use super::{camera_hit, RayStats, Termination};
use crate::material::Scratch;
use crate::math::{Spectrum, INV_2PI};
use crate::sampling::{warp, SampleStream};
use crate::scene::Scene;
use glam::Vec3;

/// How the direction at each hit is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HemisphereSampling {
    /// Uniformly over the hemisphere.
    Uniform,
    /// Cosine-weighted over the hemisphere.
    Cosine,
    /// From the BSDF.
    Bsdf,
}

/// The `bruteforce` integrator: pure path sampling, no light sampling.
#[derive(Debug, Clone)]
pub struct BruteForceIntegrator {
    /// Path length limits and Russian roulette.
    pub term: Termination,
    /// Whether directly visible emitters are left out of the image.
    pub hide_emitters: bool,
    /// How the direction at each hit is sampled.
    pub sampling: HemisphereSampling,
}

impl BruteForceIntegrator {
    /// Radiance arriving along `camera_ray`.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn li(
        &self,
        scene: &Scene,
        camera_ray: &crate::geometry::Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        let mut l = Spectrum::ZERO;
        let mut beta = Spectrum::ONE;
        let mut eta = 1.0f32;
        let mut ray = *camera_ray;
        let mut depth = 0u32;
        if self.term.max_depth == 0 {
            return l;
        }
        loop {
            let visible = !(depth == 0 && self.hide_emitters);
            let hit = if depth == 0 {
                camera_hit(scene, &ray, self.hide_emitters, stats)
            } else {
                stats.rays += 1;
                scene.intersect(&ray)
            };
            let Some(mut si) = hit else {
                if visible {
                    l += beta * scene.environment(ray.o, Vec3::ZERO, ray.d).0;
                }
                break;
            };
            // (With hide_emitters the camera ray has passed through emitters.)
            l += beta * scene.emitted(&si);
            if depth + 1 >= self.term.max_depth {
                break;
            }
            let bsdf = scene.bsdf(&mut si, scratch);
            let wo = si.to_local(si.wo);
            let u = rng.next_1d();
            let u2 = rng.next_2d();
            let (wi, weight, step_eta) = if self.sampling == HemisphereSampling::Bsdf || !bsdf.has_smooth() {
                let Some(bs) = bsdf.sample(wo, u, u2) else { break };
                (bs.wi, bs.weight, bs.eta)
            } else {
                // Hemisphere on the side `wo` lies on: f cos / p with p uniform or cosine.
                let (mut wi, pdf) = match self.sampling {
                    HemisphereSampling::Uniform => {
                        let w = warp::sample_uniform_hemisphere(u2);
                        (w, INV_2PI)
                    }
                    _ => {
                        let w = warp::sample_cosine_hemisphere(u2);
                        (w, warp::cosine_hemisphere_pdf(w))
                    }
                };
                if !(pdf > 0.0) {
                    break;
                }
                if wo.z < 0.0 {
                    wi = Vec3::new(wi.x, wi.y, -wi.z);
                }
                (wi, bsdf.eval(wo, wi) * (wi.z.abs() / pdf), 1.0)
            };
            beta *= weight;
            eta *= step_eta;
            ray = scene.spawn_ray(&si, si.to_world(wi));
            depth += 1;
            match self.term.survive(beta, eta, depth, rng) {
                Some(q) => beta /= q,
                None => break,
            }
        }
        l
    }
}
