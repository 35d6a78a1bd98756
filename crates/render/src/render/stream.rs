//! The stream form of the `path` integrator: a tile's samples run as a
//! stream of paths, whose rays are traced together in packets.
//!
//! A tile keeps a pool of [`POOL`] path slots. Slots are filled in the
//! canonical order (pixel by pixel, each pixel's samples by index), so the
//! first rays of a packet are consecutive samples of one pixel and nearly
//! identical. Each round traces the closest hit of every live path's ray
//! in packets of up to 16 ([`Accel::intersect_packet`]), runs each path's
//! vertex (emission, light sample, BSDF sample, Russian roulette) and
//! traces the light samples' shadow rays in packets
//! ([`Accel::occluded_packet`]), then refills the slots of paths that
//! ended. Vertices whose shape, material and light have lane kernels run in
//! lanes ([`PathIntegrator::lane_vertex`] gathers them into batches,
//! [`PathIntegrator::lane_vertices`] runs a batch), guided ones too once the
//! guide is trained; escapes into a lone environment map are evaluated in
//! lanes; a last vertex on a shape that emits nothing ends its path at once
//! ([`PathIntegrator::ends_dark`]); every other vertex runs the scalar
//! [`PathIntegrator::vertex`] (or `vertex_guided`), so every BSDF and light
//! works. A pass that trains a path guide keeps, for the paths that record
//! ([`Training`]), each direction drawn with the radiance before it and the
//! throughput after it; once the tile is done, they become the guide's
//! records in the one-path loop's order (by sample, then vertex).
//!
//! **Bitwise the scalar loop.** A path's vertices run the same code in the
//! same order with its own random stream, a pure function of (seed, pixel,
//! sample index, dimension); a packet finds each ray's single-ray hit (see
//! `accel::packet`); the light sample of a vertex is settled before the
//! next vertex, as in [`PathIntegrator::li`]; and finished samples are
//! splatted into the tile's film afterwards in the canonical order, so the
//! film's sums are those of the one-path-at-a-time loop.
//!
//! [`Accel::intersect_packet`]: crate::accel::Accel::intersect_packet
//! [`Accel::occluded_packet`]: crate::accel::Accel::occluded_packet

use super::{RenderJob, Tile, TilePixel};
use crate::accel::Hit;
use crate::geometry::Ray;
use crate::guiding::{Guide, GuideRecord};
use crate::integrator::path::{LaneBins, LaneOutcomes, PathIntegrator, PathState, Sampled};
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use crate::simd::Float;
use glam::{Vec2, Vec3};
use std::ops::Range;

/// The lane widths this build can trace packets with, widest first: 16
/// (AVX-512F), 8 (AVX2 + FMA), 1 (scalar, any CPU), as `target-cpu` allows.
pub const LANE_WIDTHS: &[usize] = &[
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    16,
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    8,
    1,
];

/// Paths in flight per tile (per thread): enough that each round's packets
/// and lane batches are nearly all full (a round ends with one short packet
/// and one short batch per kind met), few enough that their state stays in
/// the L2 cache. 1024 was 1-4 % faster than 256 on the bench scenes (the
/// same images); 2048 and 4096 gained at most 1 % more.
pub const POOL: usize = 1024;

/// A path in flight: which sample it is, its state and its random stream.
struct Slot {
    sample: usize,
    state: PathState,
    rng: SampleStream,
}

/// A sample's position in its pixel and, once its path has ended, its
/// radiance: what the film's splat takes ([`RenderJob::add_pixel_samples`]).
type Sample = (Vec2, Spectrum);

/// A thread's stream buffers, kept from tile to tile (allocated per tile
/// and pass, they cost page faults and copies of growing batches); each is
/// empty between tiles (`hits` is overwritten before it is read).
#[derive(Default)]
struct Buffers {
    slots: Vec<Slot>,
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    /// Shadow rays and the slots they belong to, side by side.
    shadow_slots: Vec<usize>,
    shadow_rays: Vec<Ray>,
    ended: Vec<bool>,
    sky_slots: Vec<usize>,
    bins: LaneBins,
}

thread_local! {
    static BUFFERS: std::cell::RefCell<Buffers> = std::cell::RefCell::new(Buffers::default());
}

/// A placeholder ray.
const EMPTY_RAY: Ray = Ray { o: Vec3::ZERO, d: Vec3::Z, t_max: 0.0 };

/// What a pass that trains a guide asks of the stream: every
/// `every`-th path (by full-film pixel index plus sample index, as the
/// one-path loop counts) gives the guide its records.
#[derive(Debug, Clone, Copy)]
pub(super) struct Training {
    pub every: u32,
    /// The full film's width, for the path's index.
    pub full_width: u32,
}

/// A direction drawn on a recording path, until the path's end gives its
/// record: the sample it belongs to, the direction, the throughput after
/// it (0 where roulette ended the path) and the radiance before it.
type Drawn = (usize, Sampled, Spectrum, Spectrum);

/// Renders `samples` of each of `pixels` with `path` (guided by `guide`,
/// when given and trained) into `tile`, in packets of `job.packet_lanes`
/// rays (0: the widest of [`LANE_WIDTHS`]). With `training`, the paths'
/// records for the guide are returned in the one-path loop's order (by
/// pixel, then sample, then vertex).
pub(super) fn render(
    job: &RenderJob,
    path: &PathIntegrator,
    guide: Option<&Guide>,
    pixels: &[TilePixel],
    samples: Range<u32>,
    tile: &mut Tile,
    training: Option<Training>,
) -> Vec<GuideRecord> {
    let lanes = if job.packet_lanes == 0 { LANE_WIDTHS[0] } else { job.packet_lanes };
    let guide = guide.filter(|g| g.trained());
    match lanes {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        16 => run::<crate::simd::F32x16>(job, path, guide, pixels, samples, tile, training),
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
        8 => run::<crate::simd::F32x8>(job, path, guide, pixels, samples, tile, training),
        1 => run::<f32>(job, path, guide, pixels, samples, tile, training),
        n => panic!("packets of {n} rays: this build has {LANE_WIDTHS:?}"),
    }
}

fn run<F: Float>(
    job: &RenderJob,
    path: &PathIntegrator,
    guide: Option<&Guide>,
    pixels: &[TilePixel],
    samples: Range<u32>,
    tile: &mut Tile,
    training: Option<Training>,
) -> Vec<GuideRecord> {
    let spp = samples.len();
    let total = pixels.len() * spp;
    let scene = &job.scene;
    let mut results: Vec<Sample> = Vec::with_capacity(total);
    // The camera rays, kept only for the AOVs.
    let aovs = tile.has_aovs();
    let mut camera_rays: Vec<Ray> = Vec::with_capacity(if aovs { total } else { 0 });
    let Buffers {
        mut slots,
        mut rays,
        mut hits,
        mut shadow_slots,
        mut shadow_rays,
        mut ended,
        mut sky_slots,
        mut bins,
    } = BUFFERS.with(|b| b.take());
    hits.resize(POOL, None);
    // Pinhole camera rays are made a lane group at a time.
    let camera_lanes = job.camera.has_pinhole_lanes() && F::WIDTH > 1;
    // Whether camera rays start paths (`PathIntegrator::start`: max_depth > 0).
    let starts_paths = path.start(&EMPTY_RAY).is_some();
    // Escaping rays that see a lone envmap are evaluated in lanes.
    let sky = scene.single_envmap().filter(|_| F::WIDTH > 1);
    // Vertices run in lanes where they can (see `PathIntegrator::lane_vertex`),
    // guided by a trained guide as `vertex_guided` is.
    let vertex_lanes = F::WIDTH > 1;
    // Roulette by expected contribution once training is over.
    let roulette_guide = if training.is_some() { None } else { guide };
    // Which samples record their directions, and the directions drawn:
    // this round's (slot, direction), then every round's until the tile ends.
    let records_of = |k: usize| {
        training.is_some_and(|t| {
            let (x, y) = pixels[k / spp].global;
            let index = y as u64 * t.full_width as u64 + x as u64 + (samples.start as usize + k % spp) as u64;
            index.is_multiple_of(t.every as u64)
        })
    };
    let mut round_drawn: Vec<(usize, Sampled)> = Vec::new();
    let mut drawn: Vec<Drawn> = Vec::new();
    let env = scene.single_envmap();
    let setup = path.lane_setup(scene, env, guide);
    let mut lane_out = LaneOutcomes::default();
    let mut next = 0;
    loop {
        // Refill: the next samples in canonical order take the free slots.
        while slots.len() < POOL && next < total {
            let n = (POOL - slots.len()).min(total - next).min(F::WIDTH);
            if camera_lanes && n == F::WIDTH {
                // As `camera_sample` for a pinhole (no aperture sample), the
                // rays of F::WIDTH samples at once. The slots are written in
                // place, field by field: a state built elsewhere and copied
                // in was read back in overlapping pieces that missed store
                // forwarding (about 10 % of the time on sky-lit scenes).
                let first = slots.len();
                let (mut fx, mut fy) = (F::Array::default(), F::Array::default());
                // `extend` (not `push`, whose growth call LLVM builds the
                // slot on the stack for) writes each slot where it goes.
                // A pixel's streams share its key, hashed once.
                let mut key = (usize::MAX, 0);
                slots.extend((next..next + n).map(|k| {
                    let (p, s) = (&pixels[k / spp], samples.start + (k % spp) as u32);
                    if key.0 != k / spp {
                        key = (k / spp, job.sampler.pixel_key(p.global));
                    }
                    let mut rng = job.sampler.stream_of_key(key.1, s);
                    let u = rng.next_2d();
                    let f = job.film_position(p.global, u);
                    (fx.as_mut()[k - next], fy.as_mut()[k - next]) = (f.x, f.y);
                    results.push((u, Spectrum::ZERO));
                    Slot { sample: k, state: PathState::camera(&EMPTY_RAY), rng }
                }));
                let rays = job.camera.pinhole_rays::<F>(F::from_array(fx), F::from_array(fy));
                for (slot, ray) in slots[first..].iter_mut().zip(rays.rays()) {
                    slot.state.aim(&ray);
                    if roulette_guide.is_some() {
                        slot.state.set_target(path.roulette_target(roulette_guide, pixels[slot.sample / spp].global));
                    }
                    if aovs {
                        camera_rays.push(ray);
                    }
                }
                if !starts_paths {
                    slots.truncate(first);
                }
                next += n;
                continue;
            }
            let (p, s) = (&pixels[next / spp], samples.start + (next % spp) as u32);
            let mut rng = job.sampler.stream(p.global, s);
            let (u, ray) = job.camera_sample(p.global, &mut rng);
            results.push((u, Spectrum::ZERO));
            if aovs {
                camera_rays.push(ray);
            }
            if let Some(mut state) = path.start(&ray) {
                state.set_target(path.roulette_target(roulette_guide, p.global));
                slots.push(Slot { sample: next, state, rng });
            }
            next += 1;
        }
        if slots.is_empty() {
            break;
        }
        // Closest hits, a packet of consecutive slots at a time.
        rays.clear();
        rays.extend(slots.iter().map(|s| s.state.ray));
        for (r, h) in rays.chunks(F::WIDTH).zip(hits.chunks_mut(F::WIDTH)) {
            scene.accel.intersect_packet::<F>(r, &scene.shapes, &scene.instances, h);
        }
        tile.stats.rays.rays += slots.len() as u64;
        tile.stats.rays.packet_rays += slots.len() as u64;
        let packets = slots.len().div_ceil(F::WIDTH) as u64;
        tile.stats.rays.packets += packets;
        tile.stats.rays.packet_lanes += packets * F::WIDTH as u64;
        // Escapes into a lone envmap: its radiance (after the camera or a
        // specular bounce) or radiance and density (after other bounces, for
        // the MIS weight) in lanes, bitwise `vertex`'s.
        sky_slots.clear();
        if let Some((env_index, env)) = sky {
            let seen = |st: &PathState| !st.prev_delta() || path.delta_miss_seen(st);
            sky_slots.extend((0..slots.len()).filter(|&i| hits[i].is_none() && seen(&slots[i].state)));
            for chunk in sky_slots.chunks(F::WIDTH) {
                // The directions in lanes, each read once; short chunks
                // repeat their last direction.
                let mut d = [F::Array::default(); 3];
                for l in 0..F::WIDTH {
                    let v = slots[chunk[l.min(chunk.len() - 1)]].state.ray.d;
                    (d[0].as_mut()[l], d[1].as_mut()[l], d[2].as_mut()[l]) = (v.x, v.y, v.z);
                }
                let [dx, dy, dz] = d.map(F::from_array);
                if chunk.iter().all(|&i| slots[i].state.prev_delta()) {
                    let le = env.eval_lanes(dx, dy, dz).to_lanes();
                    for (&i, le) in chunk.iter().zip(le) {
                        PathIntegrator::add_delta_miss(&mut slots[i].state, Spectrum::ZERO + le);
                    }
                    continue;
                }
                let (le, pdf) = env.eval_pdf_lanes(dx, dy, dz);
                let (le, pdf) = (le.to_lanes(), pdf.to_array());
                for (&i, (le, &pdf)) in chunk.iter().zip(le.into_iter().zip(pdf.as_ref())) {
                    let st = &mut slots[i].state;
                    if st.prev_delta() {
                        PathIntegrator::add_delta_miss(st, Spectrum::ZERO + le);
                    } else {
                        let (p_ref, n_ref) = st.prev_vertex();
                        let mut sum = (Spectrum::ZERO, 0.0);
                        scene.add_environment(&mut sum, p_ref, n_ref, env_index, (le, pdf));
                        path.add_mis_miss(st, sum.0, sum.1);
                    }
                }
            }
        }
        // One vertex per path: diffuse vertices gathered for lanes, the
        // others one at a time.
        shadow_slots.clear();
        shadow_rays.clear();
        ended.clear();
        let mut sky_done = sky_slots.iter().peekable();
        // Runs batch `$at` of `bins`, applies its outcomes and empties it.
        macro_rules! run_batch {
            ($at:expr) => {{
                let b = bins.batch($at);
                path.lane_vertices::<F>(
                    env.map(|e| e.1),
                    scene.lane_tables(),
                    scene.lane_light_table(),
                    guide,
                    b,
                    &mut lane_out,
                );
                tile.stats.rays.lane_vertices += b.len() as u64;
                tile.stats.rays.vertex_lanes += if b.is_empty() { 0 } else { F::WIDTH as u64 };
                for l in 0..b.len() {
                    let i = b.slot(l);
                    let slot = &mut slots[i];
                    let (shadow, go_on) = path.lane_vertex_done(&mut slot.state, &lane_out, l, &mut slot.rng);
                    if training.is_some() {
                        round_drawn.extend(lane_out.sampled(l).map(|s| (i, s)));
                    }
                    if shadow {
                        shadow_slots.push(i);
                        shadow_rays.push(lane_out.shadow_ray(l));
                    }
                    ended[i] = !go_on;
                }
                b.clear();
            }};
        }
        for i in 0..slots.len() {
            if sky_done.next_if_eq(&&i).is_some() {
                ended.push(true);
                continue;
            }
            let slot = &mut slots[i];
            if hits[i].as_ref().is_some_and(|h| path.ends_dark(scene, &slot.state, h)) {
                ended.push(true);
                continue;
            }
            if let (true, Some(h)) = (vertex_lanes, &hits[i]) {
                if let Some(at) = path.lane_vertex(scene, &setup, &mut slot.state, h, &mut slot.rng, i, &mut bins) {
                    ended.push(false);
                    if bins.batch(at).len() == F::WIDTH {
                        run_batch!(at);
                    }
                    continue;
                }
            }
            let ray = slot.state.ray;
            let si = hits[i].map(|h| scene.interaction(&ray, &h));
            tile.scratch.reset();
            let v = match guide {
                Some(_) => path.vertex_guided(scene, &mut slot.state, si, &mut slot.rng, &tile.scratch, guide),
                None => path.vertex(scene, &mut slot.state, si, &mut slot.rng, &tile.scratch),
            };
            if let Some(r) = v.shadow {
                shadow_slots.push(i);
                shadow_rays.push(r);
            }
            if training.is_some() {
                round_drawn.extend(v.sampled.map(|s| (i, s)));
            }
            ended.push(!v.go_on);
        }
        // (Without lanes no batch is ever filled: the test lets a scalar build drop the lane kernels.)
        for at in 0..if vertex_lanes { bins.count() } else { 0 } {
            run_batch!(at);
        }
        // Shadow rays, then each verdict before the path's next vertex.
        tile.stats.rays.shadow_rays += shadow_rays.len() as u64;
        tile.stats.rays.packet_rays += shadow_rays.len() as u64;
        let packets = shadow_rays.len().div_ceil(F::WIDTH) as u64;
        tile.stats.rays.packets += packets;
        tile.stats.rays.packet_lanes += packets * F::WIDTH as u64;
        for (k, chunk) in shadow_rays.chunks(F::WIDTH).enumerate() {
            let blocked = scene.accel.occluded_packet::<F>(chunk, &scene.shapes, &scene.instances);
            for j in 0..chunk.len() {
                let slot = shadow_slots[k * F::WIDTH + j];
                slots[slot].state.shadow_done(blocked >> j & 1 != 0);
            }
        }
        // A recording path's direction keeps its throughput after it and
        // the radiance before it, the light sample's included (as `li_guided`).
        for (i, s) in round_drawn.drain(..) {
            let (k, st) = (slots[i].sample, &slots[i].state);
            if records_of(k) {
                drawn.push((k, s, if ended[i] { Spectrum::ZERO } else { st.throughput() }, st.radiance()));
            }
        }
        // Retire ended paths; the others keep their order.
        let mut i = 0;
        slots.retain(|s| {
            let keep = !ended[i];
            if !keep {
                results[s.sample].1 = s.state.radiance();
            }
            i += 1;
            keep
        });
    }
    // Every slot has retired and every batch has run: the buffers go back empty.
    BUFFERS.with(|b| b.replace(Buffers { slots, rays, hits, shadow_slots, shadow_rays, ended, sky_slots, bins }));
    // Records in the one-path loop's order: by sample (pixel, then sample
    // index), each path's in vertex order (rounds are in order, and the
    // counting sort by sample keeps it; a comparison sort moving the
    // entries took 3 % of a guided render). Only training passes draw any.
    let records = if drawn.is_empty() {
        Vec::new()
    } else {
        let (_, order) = crate::math::counting_order(drawn.iter().map(|d| d.0), results.len());
        order
            .iter()
            .filter_map(|&i| {
                let (k, s, beta, before) = drawn[i as usize];
                PathIntegrator::record(results[k].1, s, beta, before)
            })
            .collect()
    };
    // Splat in canonical order, a pixel's samples at a time where no AOVs need the rays.
    if aovs {
        for (k, (&(u, l), ray)) in results.iter().zip(&camera_rays).enumerate() {
            let (p, s) = (&pixels[k / spp], samples.start + (k % spp) as u32);
            job.add_sample(tile, p, s, u, ray, l, &[]);
        }
    } else {
        for (p, rs) in pixels.iter().zip(results.chunks(spp.max(1))) {
            job.add_pixel_samples(tile, p, rs);
        }
    }
    records
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::path::LaneBatch;

    /// The pool (POOL slots, at most 256 KiB: within the L2 cache of the
    /// AMD EPYC and Intel Xeon machines), a batch of lane vertices (one per
    /// kind met) and a pass's finished samples stay small enough for the L1
    /// and L2 caches: print and bound their sizes. A batch's rows that its kind
    /// does not read are never touched (a smooth mesh's normals, a guided
    /// vertex's guide), so the cache holds at most 62 rows (4 KiB) of an
    /// unguided batch; the bound is on the whole.
    #[test]
    fn pool_sizes() {
        let (slot, sample) = (std::mem::size_of::<Slot>(), std::mem::size_of::<Sample>());
        let batch = std::mem::size_of::<LaneBatch>();
        eprintln!("slot {slot} B, pool {} KiB; lane batch {batch} B; finished sample {sample} B", slot * POOL / 1024);
        assert!(slot * POOL <= 256 * 1024, "slot {slot} B");
        assert!(batch <= 6 * 1024, "lane batch {batch} B");
        assert!(sample <= 24, "sample {sample} B");
    }
}
