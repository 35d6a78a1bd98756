//! Ray-traversal benchmark: BVH build time and closest-hit / any-hit
//! throughput on a procedural mesh of about a million triangles with
//! incoherent rays, next to Embree 3 on the same triangles and rays when
//! Penumbra is built with the `embree` feature.
//!
//! The mesh is a "cave": a UV sphere whose radius is displaced by smooth
//! waves plus per-vertex noise, seen from inside. Closest-hit rays are
//! diffuse bounces: they start at uniformly chosen points of the inner
//! surface and leave in cosine-distributed directions about the normal, so
//! every ray crosses the cave in a random direction (no coherence at all).
//! Any-hit rays are shadow segments between two random surface points.

use glam::{Vec2, Vec3};
use penumbra_render::accel::{Accel, Instance};
use penumbra_render::geometry::{Mesh, Ray, Shape, TriangleMesh};
use penumbra_render::sampling::rng::{hash_words, to_unit_f32};
use penumbra_render::sampling::warp;
use rayon::prelude::*;
use std::time::Instant;

/// A displaced UV sphere with about `target` triangles (`nu` x `nu/2` quads,
/// two triangles each; the pole rows hold degenerate ones, as real scanned
/// meshes often do).
pub fn cave_mesh(target: usize) -> TriangleMesh {
    let nu = ((target as f64).sqrt().round() as u32).max(8);
    let nv = nu / 2;
    let mut m = TriangleMesh::default();
    m.positions.reserve(((nv + 1) * nu) as usize);
    for j in 0..=nv {
        let theta = std::f32::consts::PI * j as f32 / nv as f32;
        for i in 0..nu {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / nu as f32;
            let noise = to_unit_f32(hash_words(&[j as u64, i as u64, 77])) - 0.5;
            let r = 1.0
                + 0.15 * (5.0 * theta).sin() * (7.0 * phi).cos()
                + 0.05 * (23.0 * theta + 1.0).sin() * (19.0 * phi).sin()
                + 0.02 * noise * theta.sin();
            m.positions.push(r * Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    m.indices.reserve((2 * nu * nv) as usize);
    for j in 0..nv {
        for i in 0..nu {
            let a = j * nu + i;
            let b = j * nu + (i + 1) % nu;
            let (c, d) = (a + nu, b + nu);
            m.indices.push([a, c, b]);
            m.indices.push([b, c, d]);
        }
    }
    m
}

/// A uniformly chosen point of the surface (by triangle index, then
/// uniform barycentrics) and the face normal turned towards the inside.
fn surface_point(m: &TriangleMesh, key: u64) -> Option<(Vec3, Vec3)> {
    let n_tri = m.indices.len() as u64;
    let t = m.indices[(hash_words(&[key, 1]) % n_tri) as usize];
    let [a, b, c] = t.map(|i| m.positions[i as usize]);
    let n = (b - a).cross(c - a);
    if n.length_squared() == 0.0 {
        return None;
    }
    let u = Vec2::new(to_unit_f32(hash_words(&[key, 2])), to_unit_f32(hash_words(&[key, 3])));
    let bary = warp::sample_uniform_triangle(u);
    let p = a * (1.0 - bary.x - bary.y) + b * bary.x + c * bary.y;
    let mut n = n.normalize();
    if n.dot(p) > 0.0 {
        n = -n;
    }
    Some((p + n * 1e-4, n))
}

/// `count` diffuse-bounce rays (closest hit) and `count` shadow segments
/// (any hit), a pure function of `count`.
pub fn incoherent_rays(m: &TriangleMesh, count: usize) -> (Vec<Ray>, Vec<Ray>) {
    let bounce = (0..count as u64 * 2)
        .into_par_iter()
        .filter_map(|k| {
            let (o, n) = surface_point(m, k)?;
            let u = Vec2::new(to_unit_f32(hash_words(&[k, 4])), to_unit_f32(hash_words(&[k, 5])));
            let local = warp::sample_cosine_hemisphere(u);
            let frame = penumbra_render::math::Frame::from_normal(n);
            Some(Ray::new(o, frame.to_world(local).normalize(), f32::INFINITY))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .take(count)
        .collect();
    let shadow = (0..count as u64 * 2)
        .into_par_iter()
        .filter_map(|k| {
            let (o, _) = surface_point(m, k + (1 << 40))?;
            let (q, _) = surface_point(m, k + (2 << 40))?;
            let dist = (q - o).length();
            (dist > 1e-3).then(|| Ray::new(o, (q - o) / dist, dist * 0.999))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .take(count)
        .collect();
    (bounce, shadow)
}

/// One engine's ray queries over a slice of rays (run on one thread; the
/// benchmark splits the rays into chunks across the pool).
pub trait Tracer: Sync {
    /// Closest hits found and the sum of their distances.
    fn closest(&self, rays: &[Ray]) -> (u64, f64);
    /// Segments found occluded.
    fn occluded(&self, rays: &[Ray]) -> u64;
}

/// Penumbra's BVH over its shapes: the benchmark mesh's, or a scene's
/// (with its instances).
pub struct Bvh<'a> {
    pub accel: &'a Accel,
    pub shapes: &'a [Shape],
    pub instances: &'a [Instance],
}

/// The benchmark mesh as a shape, its BVH, and the build time in seconds.
fn build_bvh(mesh: &TriangleMesh) -> (Vec<Shape>, Accel, f64) {
    let shapes = vec![Shape::Mesh(Mesh::new(mesh.clone(), false))];
    let start = Instant::now();
    let accel = Accel::build_shapes(&shapes);
    let secs = start.elapsed().as_secs_f64();
    (shapes, accel, secs)
}

impl Tracer for Bvh<'_> {
    fn closest(&self, rays: &[Ray]) -> (u64, f64) {
        let (mut n, mut ts) = (0u64, 0f64);
        for r in rays {
            if let Some(h) = self.accel.intersect(r, self.shapes, self.instances) {
                n += 1;
                ts += h.t as f64;
            }
        }
        (n, ts)
    }
    fn occluded(&self, rays: &[Ray]) -> u64 {
        rays.iter().filter(|r| self.accel.occluded(r, self.shapes, self.instances)).count() as u64
    }
}

/// Runs `f` with Embree's BVH over the mesh and its build time, or returns
/// `None` when Embree is not compiled in (or its device fails).
#[cfg(feature = "embree")]
pub use super::embree::{with_embree, with_embree_shapes};

/// Embree is not compiled in: no column.
#[cfg(not(feature = "embree"))]
pub fn with_embree<R>(_: &TriangleMesh, _: impl FnOnce(&dyn Tracer, f64) -> R) -> Option<R> {
    None
}

/// Embree is not compiled in: no column.
#[cfg(not(feature = "embree"))]
pub fn with_embree_shapes<R>(
    _: &[penumbra_render::accel::Primitive],
    _: &[Shape],
    _: impl FnOnce(&dyn Tracer) -> R,
) -> Result<R, String> {
    Err("Embree is not compiled in (build with --features embree)".into())
}

/// Times one pass of a query over all rays in parallel chunks; returns
/// (Mrays/s, result).
fn timed<R: Send>(rays: &[Ray], f: impl Fn(&[Ray]) -> R + Sync, sum: impl Fn(Vec<R>) -> R) -> (f64, R) {
    let start = Instant::now();
    let parts: Vec<R> = rays.par_chunks(4096).map(&f).collect();
    let secs = start.elapsed().as_secs_f64();
    (rays.len() as f64 / secs / 1e6, sum(parts))
}

/// One engine's figures: medians over the rounds, and the hit statistics
/// (the same in every round; the engines must agree on them).
#[derive(Default)]
struct Figures {
    build_s: Vec<f64>,
    closest: Vec<f64>,
    any: Vec<f64>,
    hits: u64,
    t_sum: f64,
    occluded: u64,
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One timed pass of each query.
fn pass(t: &dyn Tracer, bounce: &[Ray], shadow: &[Ray], f: &mut Figures) {
    let (mrays, (hits, t_sum)) =
        timed(bounce, |c| t.closest(c), |v| v.into_iter().fold((0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1)));
    f.closest.push(mrays);
    (f.hits, f.t_sum) = (hits, t_sum);
    let (mrays, occluded) = timed(shadow, |c| t.occluded(c), |v| v.into_iter().sum());
    f.any.push(mrays);
    f.occluded = occluded;
}

/// Alternating timed rounds of the two engines: the machines are noisy, and
/// interleaving exposes both to the same load.
const ROUNDS: usize = 5;

/// Prints the ray-traversal table.
pub fn table(pool: &rayon::ThreadPool, triangles: usize, rays: usize) {
    let mesh = cave_mesh(triangles);
    let (bounce, shadow) = pool.install(|| incoherent_rays(&mesh, rays));
    println!(
        "\nray traversal: {} triangles (displaced sphere seen from inside), {} diffuse-bounce rays (closest hit), {} shadow segments (any hit); medians of {ROUNDS} alternating rounds",
        mesh.indices.len(),
        bounce.len(),
        shadow.len()
    );
    let (mut ours, mut theirs) = (Figures::default(), Figures::default());
    let mut ratios = (Vec::new(), Vec::new());
    pool.install(|| {
        let mut built = None;
        for _ in 0..3 {
            let (shapes, accel, secs) = build_bvh(&mesh);
            ours.build_s.push(secs);
            built = Some((shapes, accel));
        }
        let (shapes, accel) = built.expect("built");
        let pen = Bvh { accel: &accel, shapes: &shapes, instances: &[] };
        let (nodes, blocks, fill) = pen.accel.stats();
        eprintln!(
            "penumbra BVH: {nodes} nodes ({fill:.2} children each), {blocks} triangle blocks ({:.2} triangles each), {:.1} bytes/triangle",
            pen.accel.triangle_count() as f64 / blocks as f64,
            pen.accel.memory_bytes() as f64 / pen.accel.triangle_count() as f64
        );
        let warm = &bounce[..bounce.len().min(20_000)];
        pen.closest(warm);
        for _ in 0..2 {
            if let Some(secs) = with_embree(&mesh, |_, secs| secs) {
                theirs.build_s.push(secs);
            }
        }
        let embree = with_embree(&mesh, |emb, secs| {
            theirs.build_s.push(secs);
            emb.closest(warm);
            for _ in 0..ROUNDS {
                pass(&pen, &bounce, &shadow, &mut ours);
                pass(emb, &bounce, &shadow, &mut theirs);
                let (o, t) = (ours.closest.len() - 1, theirs.closest.len() - 1);
                ratios.0.push(ours.closest[o] / theirs.closest[t]);
                ratios.1.push(ours.any[o] / theirs.any[t]);
            }
        });
        if embree.is_none() {
            for _ in 0..ROUNDS {
                pass(&pen, &bounce, &shadow, &mut ours);
            }
        }
    });
    println!(
        "{:<10} {:>9} {:>15} {:>15} {:>12} {:>10}",
        "engine", "build s", "closest Mrays/s", "any-hit Mrays/s", "hits", "mean t"
    );
    let row = |name: &str, r: &Figures| {
        println!(
            "{name:<10} {:>9.2} {:>15.3} {:>15.3} {:>12} {:>10.5}",
            median(&r.build_s),
            median(&r.closest),
            median(&r.any),
            r.hits,
            r.t_sum / r.hits.max(1) as f64
        );
    };
    row("penumbra", &ours);
    if theirs.closest.is_empty() {
        println!("(Embree column: build with `cargo build --release --features embree`; needs Debian's libembree-dev)");
        return;
    }
    row("embree", &theirs);
    println!(
        "penumbra / embree throughput (median of per-round ratios): closest {:.2}x, any hit {:.2}x (1.0 = equal; target >= 0.80, i.e. within 1.25x)",
        median(&ratios.0),
        median(&ratios.1)
    );
    if ours.hits != theirs.hits || ours.occluded != theirs.occluded {
        println!(
            "note: hit counts differ (penumbra {}/{} vs embree {}/{} closest/occluded): grazing rays",
            ours.hits, ours.occluded, theirs.hits, theirs.occluded
        );
    }
}
