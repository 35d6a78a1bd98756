//! The render loop: 16×16 tiles rendered in parallel with rayon. Each tile
//! splats its samples (in pixel and sample-index order) into a film of its
//! own with the filter's margin, and the tile films are added in tile order,
//! so the film is bitwise identical for any thread count or scheduling.

mod particles;
mod stream;
pub use stream::LANE_WIDTHS;

use crate::camera::Camera;
use crate::film::{Film, FilmLayers, Filter, MAX_MARGIN};
use crate::geometry::Ray;
use crate::guiding::roulette::PixelEstimate;
use crate::guiding::{Guide, GuideRecord, SPATIAL_THRESHOLD};
use crate::integrator::aov;
use crate::integrator::{Guiding, Integrator, RayStats};
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::{SampleStream, Sampler};
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
    /// Geometry, materials and lights.
    pub scene: Scene,
    /// The sensor.
    pub camera: Camera,
    /// How radiance along camera rays is estimated.
    pub integrator: Integrator,
    /// Sample generator and samples per pixel.
    pub sampler: Sampler,
    /// Pixel reconstruction filter.
    pub filter: Filter,
    /// Size of the rendered image (the crop window when there is one).
    pub width: u32,
    /// Height of the rendered image in pixels.
    pub height: u32,
    /// The crop window's offset and the full film size the camera spans
    /// (Mitsuba's `crop_offset_*` and `width`/`height`).
    pub crop_offset: (u32, u32),
    /// Full film width and height in pixels.
    pub full_size: (u32, u32),
    /// Render `path` with the stream integrator (`render/stream.rs`), whose
    /// image is bitwise the one-path-at-a-time loop's.
    pub stream: bool,
    /// Rays per packet in the stream integrator: 0 for the widest lanes the
    /// build has, else one of [`LANE_WIDTHS`] (the image is the same).
    pub packet_lanes: usize,
}

/// What a render pass did.
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderStats {
    /// Camera samples taken.
    pub samples: u64,
    /// Rays traced, by kind.
    pub rays: RayStats,
    /// Samples dropped because their radiance or weight was NaN or infinite.
    pub non_finite: u64,
    /// Path guiding: training records the guide learnt from.
    pub guide_records: u64,
    /// Path guiding: seconds the guide's updates took (after the passes' rendering).
    pub guide_seconds: f64,
}

impl RenderStats {
    /// Adds another pass's or thread's counts.
    pub fn add(&mut self, o: &RenderStats) {
        self.samples += o.samples;
        self.rays.add(&o.rays);
        self.non_finite += o.non_finite;
        self.guide_records += o.guide_records;
        self.guide_seconds += o.guide_seconds;
    }
}

/// A tile's film; its pixel (0, 0) is image pixel (x0, y0).
struct TileResult {
    x0: i32,
    y0: i32,
    film: Film,
    stats: RenderStats,
    /// The guide's training records, in sample order.
    records: Vec<GuideRecord>,
}

/// Paths of a training pass that give the guide records: beyond this, only
/// every k-th path does (each gives up to one 24-byte record per bounce).
pub const MAX_TRAINING_PATHS: u64 = 1 << 20;

impl RenderJob {
    /// Adds samples `samples` (sample indices) of every pixel to `film`.
    /// `progress` is called after each tile with the samples it added.
    /// With path guiding, a new guide learns from passes of 1, 1, 2, 4, …
    /// samples while within its training budget (as the command line's
    /// schedule), and guides the rest, rendered in one pass.
    pub fn render_into(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let never = AtomicBool::new(false);
        let Some(mut guide) = self.new_guide() else {
            return self.render_pass(film, samples, progress, &never).expect("not cancelled");
        };
        let mut stats = RenderStats::default();
        let (mut start, mut pass) = (samples.start, 0u32);
        while start < samples.end {
            let done = start - samples.start;
            let train = self.trains_guide(done);
            let end = if train { (start + (1u32 << pass.saturating_sub(1))).min(samples.end) } else { samples.end };
            let guide = Some((&mut guide, train));
            let s = self.render_pass_guided(film, start..end, None, guide, progress, &never).expect("not cancelled");
            stats.add(&s);
            (start, pass) = (end, pass + 1);
        }
        stats
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
        self.render_pass_guided(film, samples, active, None, progress, cancel)
    }

    /// Whether the pass that starts after `spp_done` samples per pixel
    /// trains the path integrator's guide: with guiding on, while the
    /// samples rendered are below the training budget's share of the
    /// sampler's count.
    pub fn trains_guide(&self, spp_done: u32) -> bool {
        spp_done < self.guide_training_spp()
    }

    /// The path integrator's guiding parameters (`None`: no guiding).
    fn guiding(&self) -> Option<Guiding> {
        match &self.integrator {
            Integrator::Path(p) => p.guiding,
            _ => None,
        }
    }

    /// The share of a render's time (or samples) that trains the path
    /// integrator's guide: its `guiding_budget` (0 without guiding).
    pub fn guide_training_share(&self) -> f64 {
        self.guiding().map_or(0.0, |g| g.budget as f64)
    }

    /// Samples per pixel whose passes train the guide: the budget's share
    /// of the sampler's count, rounded up (0 without guiding).
    pub fn guide_training_spp(&self) -> u32 {
        self.guiding().map_or(0, |g| (g.budget as f64 * self.sampler.spp as f64).ceil() as u32)
    }

    /// A new guide for this scene when the path integrator guides.
    pub fn new_guide(&self) -> Option<Guide> {
        self.guiding().map(|_| Guide::new(self.scene.bounds()))
    }

    /// As [`render_pass_masked`](Self::render_pass_masked), with path
    /// guiding: vertices are guided by `guide` once it is trained, and
    /// with `train` the pass's records (in tile order) update it afterwards.
    /// Training passes and the guided passes after them run in the stream,
    /// lanes and all (each tile's records in the one-path loop's order).
    pub fn render_pass_guided(
        &self,
        film: &mut Film,
        samples: Range<u32>,
        active: Option<&[bool]>,
        guide: Option<(&mut Guide, bool)>,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> Option<RenderStats> {
        let (mut guide, train) = match guide {
            Some((g, train)) => (Some(g), train),
            None => (None, false),
        };
        if let (Some(g), true) = (guide.as_deref_mut(), train) {
            // A training pass renders into a film of its own and is then
            // added: its image, which roulette after training compares paths
            // with, is thus the same whatever the film held before (a part
            // that does not keep the training passes renders them on a
            // blank film).
            let mut own = Film::with_layers(film.width, film.height, &film.layers());
            let (mut stats, records) =
                self.render_pass_inner(&mut own, samples, active, Some(&*g), true, progress, cancel)?;
            film.merge(&own);
            let t = std::time::Instant::now();
            let image = own.develop().iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
            g.set_image(PixelEstimate::new(self.crop_offset, own.width, own.height, image));
            g.update(&records, self.guiding().map_or(SPATIAL_THRESHOLD, |g| g.spatial_threshold as f64));
            stats.guide_records += records.len() as u64;
            stats.guide_seconds += t.elapsed().as_secs_f64();
            return Some(stats);
        }
        let (stats, _) = self.render_pass_inner(film, samples, active, guide.as_deref(), false, progress, cancel)?;
        Some(stats)
    }

    #[allow(clippy::too_many_arguments)]
    fn render_pass_inner(
        &self,
        film: &mut Film,
        samples: Range<u32>,
        active: Option<&[bool]>,
        guide: Option<&Guide>,
        train: bool,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> Option<(RenderStats, Vec<GuideRecord>)> {
        assert_eq!((film.width, film.height), (self.width, self.height));
        if let Some(a) = active {
            assert_eq!(a.len(), film.acc.len());
        }
        if let Integrator::PTracer(pt) = &self.integrator {
            return self.render_particles(pt, film, samples, progress, cancel).map(|s| (s, Vec::new()));
        }
        assert!(
            film.channels.is_empty() || film.channels == self.integrator.channel_names(),
            "the film's channels are not the integrator's"
        );
        let layers = film.layers();
        // Samples are taken in the image and, for a crop window, in the ring
        // of pixels around it whose splats reach into it (so a crop holds
        // exactly the contributions the full frame gives those pixels).
        let (left, top, right, bottom) = self.sample_ring();
        let (gw, gh) = (self.width + left + right, self.height + top + bottom);
        // A training pass of more paths than MAX_TRAINING_PATHS records
        // every k-th (by pixel and sample index), which bounds its records' memory.
        let record_every = match train {
            true => {
                (gw as u64 * gh as u64 * samples.len() as u64).div_ceil(MAX_TRAINING_PATHS).clamp(1, u32::MAX as u64)
            }
            false => 0,
        } as u32;
        let tiles_x = gw.div_ceil(TILE);
        let tiles_y = gh.div_ceil(TILE);
        let results: Option<Vec<TileResult>> = (0..tiles_x * tiles_y)
            .into_par_iter()
            .map(|t| {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let (tx, ty) = (t % tiles_x * TILE, t / tiles_x * TILE);
                let size = (TILE.min(gw - tx), TILE.min(gh - ty));
                let (x0, y0) = (tx as i32 - left as i32, ty as i32 - top as i32);
                let r = self.render_tile(x0, y0, size, samples.clone(), &layers, active, guide, record_every);
                progress(r.stats.samples);
                Some(r)
            })
            .collect();
        let results = results?;
        // The caustics' light paths, added after the tiles.
        let caustics = match &self.integrator {
            Integrator::Path(p) if p.caustics => {
                Some(self.render_caustics(p, film, samples.clone(), active, cancel)?)
            }
            _ => None,
        };
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        // Added in tile order: the sums do not depend on the scheduling.
        let mut stats = RenderStats::default();
        let mut records = Vec::new();
        for mut r in results {
            records.append(&mut r.records);
            for y in 0..r.film.height {
                let iy = r.y0 + y as i32;
                if iy < 0 || iy >= self.height as i32 {
                    continue;
                }
                for x in 0..r.film.width {
                    let ix = r.x0 + x as i32;
                    if ix < 0 || ix >= self.width as i32 {
                        continue;
                    }
                    let src = (y * r.film.width + x) as usize;
                    let dst = (iy as u32 * self.width + ix as u32) as usize;
                    film.add_pixel(dst, &r.film, src);
                }
            }
            stats.add(&r.stats);
        }
        if let Some((pass, st)) = caustics {
            film.merge(&pass);
            stats.add(&st);
        }
        Some((stats, records))
    }

    /// Pixels sampled beyond the image on each side (left, top, right,
    /// bottom): those of the full film within the filter's reach of a crop
    /// window; none for a full frame, as Mitsuba (`sample_border` false).
    fn sample_ring(&self) -> (u32, u32, u32, u32) {
        let m = self.filter.margin().min(MAX_MARGIN);
        let (cx, cy) = self.crop_offset;
        (m.min(cx), m.min(cy), m.min(self.full_size.0 - cx - self.width), m.min(self.full_size.1 - cy - self.height))
    }

    /// Where a camera ray through film position `s` leaves the camera:
    /// back along it to the lens plane (z = 0 in camera space; rays start on
    /// the near clip plane), or its origin for orthographic cameras; for a
    /// batch, as the strip's own sensor.
    fn eye(&self, s: Vec2, ray: &crate::geometry::Ray, camera_from_world: &glam::Mat4) -> glam::Vec3 {
        if self.camera.projection == crate::camera::Projection::Batch {
            // Only AOV queries ask: the strip sensor's inverse per call.
            let (c, _) = self.camera.sensor_at(s);
            return eye(c, ray, &c.world_from_camera.inverse());
        }
        eye(&self.camera, ray, camera_from_world)
    }

    /// Renders the pixels [x0, x0+w) × [y0, y0+h) (image coordinates; may
    /// start in the crop ring) into a film with the filter's margin. With
    /// `active`, only pixels marked there take samples (ring pixels follow
    /// the nearest image pixel). Path vertices are guided by `guide` and,
    /// with `record_every` k > 0 (a training pass), every k-th path (by
    /// pixel and sample index) gives the guide's training records.
    #[allow(clippy::too_many_arguments)]
    fn render_tile(
        &self,
        x0: i32,
        y0: i32,
        (w, h): (u32, u32),
        samples: Range<u32>,
        layers: &FilmLayers,
        active: Option<&[bool]>,
        guide: Option<&Guide>,
        record_every: u32,
    ) -> TileResult {
        let m = self.filter.margin().min(MAX_MARGIN);
        let mut tile = Tile {
            film: Film::with_layers(w + 2 * m, h + 2 * m, layers),
            aov_values: Vec::new(),
            splat_buf: Vec::new(),
            scratch: Scratch::new(),
            camera_from_world: self.camera.world_from_camera.inverse(),
            stats: RenderStats::default(),
            margin: m,
        };
        tile.aov_values = vec![0f32; tile.film.aov_channels()];
        let pixels = self.tile_pixels(x0, y0, (w, h), active);
        let train = record_every > 0;
        let guided = train || guide.is_some_and(|g| g.trained());
        let mut records = Vec::new();
        match (&self.integrator, self.stream && self.scene.ray_log.is_none()) {
            (Integrator::Path(path), true) => {
                let training = train.then_some(stream::Training { every: record_every, full_width: self.full_size.0 });
                records = stream::render(self, path, guide, &pixels, samples, &mut tile, training);
            }
            _ => {
                // The integrator's own output channels (the `aov` and `moment` integrators').
                let mut ch = vec![0f32; self.integrator.channel_names().len()];
                // Without AOVs, a pixel's samples are splatted together.
                let by_pixel = !tile.has_aovs();
                let mut pixel: Vec<(Vec2, Spectrum)> = Vec::with_capacity(samples.len());
                for p in &pixels {
                    pixel.clear();
                    for s in samples.clone() {
                        let mut rng = self.sampler.stream(p.global, s);
                        let (u, ray) = self.camera_sample(p.global, &mut rng);
                        tile.scratch.reset();
                        let (scene, stats, scratch) = (&self.scene, &mut tile.stats.rays, &tile.scratch);
                        let l = if ch.is_empty() {
                            match &self.integrator {
                                Integrator::Path(path) if guided => {
                                    let (x, y) = p.global;
                                    let index = y as u64 * self.full_size.0 as u64 + x as u64 + s as u64;
                                    let r =
                                        (train && index.is_multiple_of(record_every as u64)).then_some(&mut records);
                                    // Roulette by expected contribution after training only.
                                    let target = if train { 0.0 } else { path.roulette_target(guide, p.global) };
                                    path.li_guided(scene, &ray, &mut rng, stats, scratch, guide, r, target)
                                }
                                i => i.li(scene, &ray, &mut rng, stats, scratch),
                            }
                        } else {
                            let diff = self.ray_diff(p.global, u, &ray);
                            self.integrator.sample(scene, &ray, diff.as_ref(), &mut rng, stats, scratch, &mut ch)
                        };
                        if by_pixel {
                            pixel.push((u, l));
                        } else {
                            self.add_sample(&mut tile, p, s, u, &ray, l, &ch);
                        }
                    }
                    if by_pixel {
                        self.add_pixel_samples(&mut tile, p, &pixel);
                    }
                }
            }
        }
        let Tile { film, stats, .. } = tile;
        TileResult { x0: x0 - m as i32, y0: y0 - m as i32, film, stats, records }
    }

    /// The pixels of the tile [x0, x0+w) × [y0, y0+h) that take samples, in
    /// the order they are summed (row by row). With `active`, only pixels
    /// marked there (ring pixels follow the nearest image pixel).
    fn tile_pixels(&self, x0: i32, y0: i32, (w, h): (u32, u32), active: Option<&[bool]>) -> Vec<TilePixel> {
        let mut out = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let (ix, iy) = (x0 + x as i32, y0 + y as i32);
                if let Some(a) = active {
                    let (cx, cy) = (ix.clamp(0, self.width as i32 - 1), iy.clamp(0, self.height as i32 - 1));
                    if !a[(cy as u32 * self.width + cx as u32) as usize] {
                        continue;
                    }
                }
                // The pixel in full-film coordinates: it keys the random
                // streams, so a crop renders exactly its part of the full image.
                let gx = (ix + self.crop_offset.0 as i32) as u32;
                let gy = (iy + self.crop_offset.1 as i32) as u32;
                out.push(TilePixel { local: (x, y), global: (gx, gy) });
            }
        }
        out
    }

    /// A camera sample of full-film pixel `global`: its position `u` in the
    /// pixel and the camera ray (the first random numbers of `rng`).
    #[inline]
    pub(crate) fn camera_sample(&self, global: (u32, u32), rng: &mut SampleStream) -> (Vec2, Ray) {
        let u = rng.next_2d();
        (u, self.camera.sample_ray(self.film_position(global, u), rng))
    }

    /// Full-film pixel `(gx, gy)` plus `u` in [0, 1)² of the film.
    #[inline]
    fn film_position(&self, (gx, gy): (u32, u32), u: Vec2) -> Vec2 {
        let inv = Vec2::new(1.0 / self.full_size.0 as f32, 1.0 / self.full_size.1 as f32);
        (Vec2::new(gx as f32, gy as f32) + u) * inv
    }

    /// The differentials of camera ray `ray` through `u` in full-film pixel
    /// `global`, as Mitsuba's sensors give them and its sampling integrators
    /// scale them (by 1/√spp); None for the radiance meter, which has none.
    pub(crate) fn ray_diff(&self, (gx, gy): (u32, u32), u: Vec2, ray: &Ray) -> Option<crate::integrator::RayDiff> {
        use crate::camera::Projection;
        let inv = Vec2::new(1.0 / self.full_size.0 as f32, 1.0 / self.full_size.1 as f32);
        let pos = (Vec2::new(gx as f32, gy as f32) + u) * inv;
        let scale = 1.0 / (self.sampler.spp as f32).sqrt();
        let c = &self.camera;
        let (rx, ry) = match c.projection {
            Projection::RadianceMeter => return None,
            _ => (c.generate_ray(pos + Vec2::new(inv.x, 0.0)), c.generate_ray(pos + Vec2::new(0.0, inv.y))),
        };
        // Pinhole and thin lens: the offset rays share the ray's origin;
        // orthographic: parallel rays from shifted origins.
        let ortho = matches!(c.projection, Projection::Orthographic { .. });
        let (o_x, d_x, o_y, d_y) = if ortho {
            (rx.o, ray.d, ry.o, ray.d)
        } else {
            let centre = c.generate_ray(pos);
            (ray.o, ray.d + (rx.d - centre.d), ray.o, ray.d + (ry.d - centre.d))
        };
        Some(crate::integrator::RayDiff {
            o_x: ray.o + (o_x - ray.o) * scale,
            d_x: ray.d + (d_x - ray.d) * scale,
            o_y: ray.o + (o_y - ray.o) * scale,
            d_y: ray.d + (d_y - ray.d) * scale,
        })
    }

    /// A sample's radiance times its camera weight, counted in the tile's
    /// statistics; `None` (counted as non-finite) when it is not finite.
    #[inline]
    fn weighted(&self, tile: &mut Tile, p: &TilePixel, u: Vec2, l: Spectrum) -> Option<Spectrum> {
        tile.stats.samples += 1;
        let l = l * self.camera.ray_weight(self.film_position(p.global, u));
        if !l.is_finite() {
            tile.stats.non_finite += 1;
            return None;
        }
        Some(l)
    }

    /// The samples of pixel `p` in sample order (position in the pixel,
    /// radiance), added as [`Self::add_sample`] adds them one by one, for a
    /// tile without AOVs or channels ([`Tile::has_aovs`]): the film's sums get the same
    /// additions in the same order, a footprint pixel at a time.
    pub(crate) fn add_pixel_samples(&self, tile: &mut Tile, p: &TilePixel, samples: &[(Vec2, Spectrum)]) {
        debug_assert!(!tile.has_aovs());
        tile.splat_buf.clear();
        for &(u, l) in samples {
            if let Some(l) = self.weighted(tile, p, u, l) {
                tile.splat_buf.push((u, l));
            }
        }
        let (x, y) = p.local;
        tile.film.splat_pixel((x + tile.margin) as i32, (y + tile.margin) as i32, &tile.splat_buf, &self.filter);
    }

    /// Splats sample `s` of pixel `p` (taken at `u` in the pixel, along
    /// `ray`, with radiance `l` and the integrator's output channels `ch`)
    /// into the tile's film with its AOVs.
    /// Samples must come in pixel and sample-index order: the film's sums
    /// are then the same however the radiance was computed.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_sample(
        &self,
        tile: &mut Tile,
        p: &TilePixel,
        s: u32,
        u: Vec2,
        ray: &Ray,
        l: Spectrum,
        ch: &[f32],
    ) {
        let Some(l) = self.weighted(tile, p, u, l) else { return };
        let (gx, gy) = p.global;
        let kinds = tile.aov_values.len() - tile.film.channels.len();
        if kinds < tile.aov_values.len() {
            tile.aov_values[kinds..].copy_from_slice(ch);
        }
        let aov = if tile.aov_values.is_empty() {
            None
        } else if kinds == 0 {
            Some(&tile.aov_values[..])
        } else {
            // Its own random numbers (a stream of a pixel no image has), so
            // the beauty is the same with or without AOVs.
            let mut aov_rng = self.sampler.stream((gx | AOV_STREAM, gy), s);
            let a = aov::query(
                &self.scene,
                &self.integrator,
                ray,
                self.eye(self.film_position(p.global, u), ray, &tile.camera_from_world),
                &mut aov_rng,
                &tile.scratch,
            );
            a.write(&tile.film.aov_kinds, &mut tile.aov_values[..kinds]);
            Some(&tile.aov_values[..])
        };
        // The pixel's place in the tile film (margin included).
        let (x, y) = p.local;
        tile.film.splat((x + tile.margin) as i32, (y + tile.margin) as i32, u, l, aov, &self.filter);
    }
}

/// Where a camera ray leaves `camera` (see [`RenderJob::eye`]).
fn eye(camera: &Camera, ray: &crate::geometry::Ray, camera_from_world: &glam::Mat4) -> glam::Vec3 {
    if matches!(
        camera.projection,
        crate::camera::Projection::Orthographic { .. }
            | crate::camera::Projection::RadianceMeter
            | crate::camera::Projection::IrradianceMeter
            | crate::camera::Projection::Distant { .. }
    ) {
        return ray.o;
    }
    let (o, d) = (camera_from_world.transform_point3(ray.o), camera_from_world.transform_vector3(ray.d));
    if d.z.abs() > 0.0 {
        ray.o - ray.d * (o.z / d.z)
    } else {
        ray.o
    }
}

/// A pixel of a tile: its place in the tile and in the full film.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TilePixel {
    pub local: (u32, u32),
    pub global: (u32, u32),
}

/// What a tile accumulates, and the buffers its samples reuse.
pub(crate) struct Tile {
    film: Film,
    aov_values: Vec<f32>,
    /// A pixel's finite samples on their way into [`Film::splat_pixel`].
    splat_buf: Vec<(Vec2, Spectrum)>,
    pub scratch: Scratch,
    camera_from_world: glam::Mat4,
    pub stats: RenderStats,
    margin: u32,
}

impl Tile {
    /// Whether samples carry AOVs or integrator channels besides radiance.
    pub(crate) fn has_aovs(&self) -> bool {
        !self.aov_values.is_empty()
    }
}
