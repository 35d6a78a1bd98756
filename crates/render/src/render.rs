//! The render loop: 16×16 tiles rendered in parallel with rayon. Each pixel
//! belongs to one tile and accumulates its samples in index order, so the
//! film is bitwise identical for any thread count or scheduling.

use crate::aov;
use crate::camera::Camera;
use crate::film::{Film, FilmLayers, Filter};
use crate::integrator::{Integrator, RayStats};
use crate::sampling::Sampler;
use crate::scene::Scene;
use glam::Vec2;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

const TILE: u32 = 16;
/// High bit set in the x key of AOV sample streams.
const AOV_STREAM: u32 = 1 << 31;

/// Everything needed to render an image of a scene.
#[derive(Debug, Clone)]
pub struct RenderJob {
    pub scene: Scene,
    pub camera: Camera,
    pub integrator: Integrator,
    pub sampler: Sampler,
    pub filter: Filter,
    /// Size of the rendered image (the crop window when there is one).
    pub width: u32,
    pub height: u32,
    /// The crop window's offset and the full film size the camera spans
    /// (Mitsuba's `crop_offset_*` and `width`/`height`).
    pub crop_offset: (u32, u32),
    pub full_size: (u32, u32),
}

/// What a render pass did.
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderStats {
    pub samples: u64,
    pub rays: RayStats,
    /// Samples dropped because their radiance or weight was NaN or infinite.
    pub non_finite: u64,
}

impl RenderStats {
    fn add(&mut self, o: &RenderStats) {
        self.samples += o.samples;
        self.rays.add(&o.rays);
        self.non_finite += o.non_finite;
    }
}

struct TileResult {
    x0: u32,
    y0: u32,
    w: u32,
    film: Film,
    stats: RenderStats,
}

impl RenderJob {
    /// Adds samples `samples` (sample indices) of every pixel to `film`.
    /// `progress` is called after each tile with the samples it added.
    pub fn render_into(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let never = AtomicBool::new(false);
        self.render_pass(film, samples, progress, &never).expect("not cancelled")
    }

    /// As [`render_into`](Self::render_into), but checks `cancel` before each
    /// tile: once it is set, the remaining tiles are skipped, the film is left
    /// untouched and `None` is returned. A pass is thus added whole or not at
    /// all, which keeps interrupted renders reproducible.
    pub fn render_pass(
        &self,
        film: &mut Film,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> Option<RenderStats> {
        self.render_pass_masked(film, samples, None, progress, cancel)
    }

    /// As [`render_pass`](Self::render_pass), restricted to the pixels whose
    /// entry of `active` (row-major, one per pixel) is true; the film's
    /// layers (AOVs, variance moments) are accumulated as the film has them.
    pub fn render_pass_masked(
        &self,
        film: &mut Film,
        samples: Range<u32>,
        active: Option<&[bool]>,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> Option<RenderStats> {
        assert_eq!((film.width, film.height), (self.width, self.height));
        if let Some(a) = active {
            assert_eq!(a.len(), film.weight.len());
        }
        let layers = film.layers();
        let tiles_x = self.width.div_ceil(TILE);
        let tiles_y = self.height.div_ceil(TILE);
        let results: Option<Vec<TileResult>> = (0..tiles_x * tiles_y)
            .into_par_iter()
            .map(|t| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let r = self.render_tile(t % tiles_x * TILE, t / tiles_x * TILE, samples.clone(), &layers, active);
                progress(r.stats.samples);
                Some(r)
            })
            .collect();
        let results = results?;
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let mut stats = RenderStats::default();
        for r in results {
            for y in 0..r.film.height {
                for x in 0..r.w {
                    let src = (y * r.w + x) as usize;
                    let dst = ((r.y0 + y) * self.width + r.x0 + x) as usize;
                    film.add_pixel(dst, &r.film, src);
                }
            }
            stats.add(&r.stats);
        }
        Some(stats)
    }

    /// Where a camera ray leaves the camera: back along it to the lens plane
    /// (z = 0 in camera space; rays start on the near clip plane), or its
    /// origin for orthographic cameras.
    fn eye(&self, ray: &crate::geometry::Ray, camera_from_world: &glam::Mat4) -> glam::Vec3 {
        if matches!(self.camera.projection, crate::camera::Projection::Orthographic { .. }) {
            return ray.o;
        }
        let (o, d) = (camera_from_world.transform_point3(ray.o), camera_from_world.transform_vector3(ray.d));
        if d.z.abs() > 0.0 {
            ray.o - ray.d * (o.z / d.z)
        } else {
            ray.o
        }
    }

    fn render_tile(
        &self,
        x0: u32,
        y0: u32,
        samples: Range<u32>,
        layers: &FilmLayers,
        active: Option<&[bool]>,
    ) -> TileResult {
        let w = TILE.min(self.width - x0);
        let h = TILE.min(self.height - y0);
        let mut film = Film::with_layers(w, h, layers);
        let mut aov_values = vec![0f32; film.aov_channels()];
        let camera_from_world = self.camera.world_from_camera.inverse();
        let mut stats = RenderStats::default();
        let inv = Vec2::new(1.0 / self.full_size.0 as f32, 1.0 / self.full_size.1 as f32);
        let origin = Vec2::new(self.crop_offset.0 as f32 + 0.5, self.crop_offset.1 as f32 + 0.5);
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x0 + x, y0 + y);
                if active.is_some_and(|a| !a[(py * self.width + px) as usize]) {
                    continue;
                }
                for s in samples.clone() {
                    // Keyed by the pixel's position in the full film, so a
                    // crop window renders exactly its part of the full image.
                    let mut rng = self.sampler.stream((px + self.crop_offset.0, py + self.crop_offset.1), s);
                    let (offset, weight) = self.filter.sample_2d(rng.next_2d());
                    let pos = (origin + Vec2::new(px as f32, py as f32) + offset) * inv;
                    let ray = self.camera.sample_ray(pos, &mut rng);
                    let l = self.integrator.li(&self.scene, &ray, &mut rng, &mut stats.rays);
                    stats.samples += 1;
                    if l.is_finite() && weight.is_finite() {
                        film.add(x, y, l, weight);
                        if !aov_values.is_empty() {
                            // Its own random numbers (a stream of a pixel no
                            // image has), so the beauty is the same with or
                            // without AOVs.
                            let key = ((px + self.crop_offset.0) | AOV_STREAM, py + self.crop_offset.1);
                            let mut aov_rng = self.sampler.stream(key, s);
                            let a = aov::query(
                                &self.scene,
                                &self.integrator,
                                &ray,
                                self.eye(&ray, &camera_from_world),
                                &mut aov_rng,
                            );
                            a.write(&film.aov_kinds, &mut aov_values);
                            film.add_aov(x, y, &aov_values, weight);
                        }
                    } else {
                        stats.non_finite += 1;
                    }
                }
            }
        }
        TileResult { x0, y0, w, film, stats }
    }
}
