//! Trace-only time: a render's own rays, recorded as the integrator asks
//! for them, replayed through the BVH alone and through Embree (when
//! compiled in) without shading, sampling or film. It is the part of a
//! render's time that traversal alone sets, and so a floor under it: a
//! render cannot be faster than its rays can be traced.

use super::rays::{Bvh, Tracer};
use penumbra_render::geometry::Ray;
use penumbra_render::render::RenderJob;
use penumbra_render::scene::{LoggedRay, RayLog};
use rayon::prelude::*;
use std::time::Instant;

/// Rounds of each engine, alternating; the median is reported.
const ROUNDS: usize = 3;

/// One scene's trace-only figures, scaled to the timed render's spp.
pub struct TraceOnly {
    /// Rays the timed render traces (closest-hit and shadow).
    pub rays: f64,
    /// Seconds Penumbra's BVH takes for them alone.
    pub penumbra_s: f64,
    /// Seconds Embree takes for the same rays, or why there is no figure.
    pub embree_s: Result<f64, String>,
    /// Closest hits and blocked shadow segments among the recorded rays,
    /// by Penumbra and by Embree (which may differ on grazing rays and
    /// where a disk is a fan of triangles).
    pub counts: [[u64; 2]; 2],
}

/// Seconds to trace the closest-hit rays and then the shadow rays, in
/// parallel chunks, with the hits and blocked segments found.
fn replay(t: &dyn Tracer, closest: &[Ray], shadow: &[Ray]) -> (f64, [u64; 2]) {
    let start = Instant::now();
    let hits: u64 = closest.par_chunks(4096).map(|c| t.closest(c).0).sum();
    let blocked: u64 = shadow.par_chunks(4096).map(|c| t.occluded(c)).sum();
    (start.elapsed().as_secs_f64(), [hits, blocked])
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Records the rays of the first `record_spp` samples per pixel of `job`
/// (samples are identically distributed, so they stand for all of them)
/// and times replaying them; times are scaled to `job`'s spp.
pub fn measure(job: &RenderJob, pool: &rayon::ThreadPool, record_spp: u32) -> TraceOnly {
    let log = RayLog::default();
    let mut rec = job.clone();
    rec.scene.ray_log = Some(log.clone());
    rec.sampler.spp = record_spp.clamp(1, job.sampler.spp.max(1));
    crate::render_job(&rec, pool, true);
    let scale = job.sampler.spp as f64 / rec.sampler.spp as f64;
    let logged = std::mem::take(&mut *log.lock().unwrap_or_else(|e| e.into_inner()));
    let (shadow, closest): (Vec<LoggedRay>, Vec<LoggedRay>) = logged.into_iter().partition(|l| l.shadow);
    let rays_of = |v: Vec<LoggedRay>| -> Vec<Ray> { v.into_iter().map(|l| l.ray).collect() };
    let (closest, shadow) = (rays_of(closest), rays_of(shadow));
    let rays = (closest.len() + shadow.len()) as f64 * scale;
    let ours = Bvh { accel: &job.scene.accel, shapes: &job.scene.shapes, instances: &job.scene.instances };
    let (mut pen, mut emb, mut counts) = (Vec::new(), Vec::new(), [[0; 2]; 2]);
    let mut round = |t: &dyn Tracer, times: &mut Vec<f64>, k: usize| {
        let (secs, n) = replay(t, &closest, &shadow);
        times.push(secs);
        counts[k] = n;
    };
    let embree = pool.install(|| {
        replay(&ours, &closest[..closest.len().min(20_000)], &[]);
        super::rays::with_embree_shapes(&job.scene.placed, &job.scene.shapes, |theirs| {
            replay(theirs, &closest[..closest.len().min(20_000)], &[]);
            for _ in 0..ROUNDS {
                round(&ours, &mut pen, 0);
                round(theirs, &mut emb, 1);
            }
        })
    });
    if embree.is_err() {
        pool.install(|| (0..ROUNDS).for_each(|_| round(&ours, &mut pen, 0)));
    }
    TraceOnly { rays, penumbra_s: median(pen) * scale, embree_s: embree.map(|_| median(emb) * scale), counts }
}
