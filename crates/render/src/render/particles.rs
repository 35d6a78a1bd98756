//! The particle tracer's pass (Mitsuba `ptracer`): light paths splat
//! anywhere on the film, so the pass is not split into image tiles but into
//! rows of the full film, the row of pixel (x, y) tracing the particles of
//! that pixel's samples (their random numbers come from its streams). Each
//! row collects its splats in a list of its own; the lists are added to a
//! pass film in row order, so the image is bitwise the same for any thread
//! count, and the pass film joins the render's film whole (or, when
//! cancelled, not at all). Every pixel's weight sum grows by the pass's
//! sample count: the developed image is Σ splats / spp, additive over
//! passes, checkpoints and parts like any other. A crop window traces the
//! particles of the full film and keeps the splats that reach it, so it is
//! exactly its part of the full image.

use super::{RenderJob, RenderStats};
use crate::film::Film;
use crate::integrator::path::CausticTargets;
use crate::integrator::ptracer::{CameraConnection, ParticleTracer, Splat};
use crate::integrator::PathIntegrator;
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use glam::Vec2;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

/// Rows of the full film traced in parallel before their splats are added
/// (bounds the memory the splat lists take).
const ROWS_PER_BATCH: u32 = 64;

impl RenderJob {
    /// Traces the particles of sample indices `samples` of every full-film
    /// pixel and adds them to `film`; None when cancelled (film untouched).
    pub(super) fn render_particles(
        &self,
        pt: &ParticleTracer,
        film: &mut Film,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> Option<RenderStats> {
        let cam = CameraConnection::new(&self.camera, self.full_size)
            .expect("ptracer needs a perspective or thin-lens camera (checked when the scene is loaded)");
        let mut pass = Film::with_layers(film.width, film.height, &film.layers());
        let stats = self.trace_rows(
            samples.clone(),
            0,
            progress,
            cancel,
            |rng, st, scratch, out| {
                pt.trace(&self.scene, &cam, rng, &mut st.rays, scratch, out);
                st.samples += 1;
            },
            |px, py, u, value| pass.splat_normalized(px, py, u, value, &self.filter),
        )?;
        let n = samples.len() as f64;
        for a in &mut pass.acc {
            a[3] += n;
        }
        film.merge(&pass);
        Some(stats)
    }
}

/// High bit set in the x key of the caustics' light-path streams (see
/// `integrator::path::caustics`): pixels no image has, so the camera
/// paths' random numbers are not the light paths'.
const CAUSTIC_STREAM: u32 = 1 << 30;

impl RenderJob {
    /// The caustics' light paths (`path`'s `caustics`) of sample indices
    /// `samples` of every full-film pixel, added to a film like `film`
    /// (layers included, all zero but Σ w·L) in row order; None when
    /// cancelled. Each splat enters Σ w·L with the filter's weights as a
    /// camera sample taken where it lands would, but not Σ w, and only where
    /// this pass takes camera samples (`active` and the crop's ring): the
    /// film's weighted mean then estimates the caustics as it does the
    /// camera paths' radiance (see `integrator::path::caustics`).
    pub(super) fn render_caustics(
        &self,
        path: &PathIntegrator,
        film: &Film,
        samples: Range<u32>,
        active: Option<&[bool]>,
        cancel: &AtomicBool,
    ) -> Option<(Film, RenderStats)> {
        let cam = CameraConnection::new(&self.camera, self.full_size)
            .expect("caustics need a perspective or thin-lens camera (checked when the scene is loaded)");
        let mut pass = Film::with_layers(film.width, film.height, &film.layers());
        let targets = CausticTargets::new(&self.scene);
        if targets.is_empty() {
            return Some((pass, RenderStats::default()));
        }
        let (left, top, right, bottom) = self.sample_ring();
        // Whether this pass takes camera samples in film pixel (x, y), as `tile_pixels` decides.
        let sampled = |x: i32, y: i32| {
            let inside = x >= -(left as i32)
                && y >= -(top as i32)
                && x < (self.width + right) as i32
                && y < (self.height + bottom) as i32;
            inside
                && active.is_none_or(|a| {
                    let (cx, cy) = (x.clamp(0, self.width as i32 - 1), y.clamp(0, self.height as i32 - 1));
                    a[(cy as u32 * self.width + cx as u32) as usize]
                })
        };
        let stats = self.trace_rows(
            samples,
            CAUSTIC_STREAM,
            &|_| {},
            cancel,
            |rng, st, scratch, out| path.trace_caustic(&self.scene, &cam, &targets, rng, &mut st.rays, scratch, out),
            |px, py, u, value| {
                if sampled(px, py) {
                    pass.splat_radiance(px, py, u, value, &self.filter);
                }
            },
        )?;
        Some((pass, stats))
    }

    /// Traces the light paths of sample indices `samples` of every full-film
    /// pixel (x, y), each from the stream of pixel (x | `x_key`, y) and
    /// sample, a row of the full film per task, and lands their finite
    /// splats in row order, each with its film pixel and the offset in it:
    /// `land(px, py, u, value)` (crop offset applied). `progress` gets each
    /// row's sample count. None when cancelled.
    fn trace_rows(
        &self,
        samples: Range<u32>,
        x_key: u32,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
        trace: impl Fn(&mut SampleStream, &mut RenderStats, &mut Scratch, &mut Vec<Splat>) + Sync,
        mut land: impl FnMut(i32, i32, Vec2, Spectrum),
    ) -> Option<RenderStats> {
        let (fw, fh) = self.full_size;
        let (ox, oy) = (self.crop_offset.0 as f32, self.crop_offset.1 as f32);
        let mut stats = RenderStats::default();
        for first in (0..fh).step_by(ROWS_PER_BATCH as usize) {
            let rows: Option<Vec<(Vec<Splat>, RenderStats)>> = (first..(first + ROWS_PER_BATCH).min(fh))
                .into_par_iter()
                .map(|gy| {
                    if cancel.load(Ordering::Relaxed) {
                        return None;
                    }
                    let (mut out, mut st, mut scratch) = (Vec::new(), RenderStats::default(), Scratch::new());
                    for gx in 0..fw {
                        // Hashed once for the pixel's streams.
                        let key = self.sampler.pixel_key((gx | x_key, gy));
                        for s in samples.clone() {
                            trace(&mut self.sampler.stream_of_key(key, s), &mut st, &mut scratch, &mut out);
                        }
                    }
                    progress(st.samples);
                    Some((out, st))
                })
                .collect();
            for (splats, st) in rows? {
                for sp in splats {
                    if !sp.value.is_finite() || !sp.pos.is_finite() {
                        stats.non_finite += 1;
                        continue;
                    }
                    let (x, y) = (sp.pos.x - ox, sp.pos.y - oy);
                    let (px, py) = (x.floor(), y.floor());
                    land(px as i32, py as i32, Vec2::new(x - px, y - py), sp.value);
                }
                stats.add(&st);
            }
        }
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        Some(stats)
    }
}
