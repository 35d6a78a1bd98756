//! Embree 3 (Debian's `libembree-dev`, through the `embree3` crate) on the
//! ray-traversal benchmark's triangles and rays: the reference for BVH
//! build time and traversal speed. Compiled only with the `embree` feature.

use super::rays::{BenchRay, TraceResult};
use embree3::{BufferUsage, Device, Format, GeometryKind, IntersectContext, Ray, RayHit};
use penumbra_render::geometry::TriangleMesh;
use rayon::prelude::*;
use std::time::Instant;

/// Builds Embree's BVH (default, medium quality) over the mesh and traces
/// the same rays with `rtcIntersect1` / `rtcOccluded1`, incoherent context.
pub fn trace_embree(mesh: &TriangleMesh, bounce: &[BenchRay], shadow: &[BenchRay]) -> Option<TraceResult> {
    let device = match Device::new() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("note: Embree device failed: {e:?}");
            return None;
        }
    };
    let start = Instant::now();
    let mut scene = device.create_scene().ok()?;
    let mut geom = device.create_geometry(GeometryKind::TRIANGLE).ok()?;
    geom.set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, mesh.positions.len())
        .ok()?
        .copy_from_slice(&mesh.positions.iter().map(|p| p.to_array()).collect::<Vec<_>>());
    geom.set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, mesh.indices.len())
        .ok()?
        .copy_from_slice(&mesh.indices);
    let geom = geom.commit();
    scene.attach_geometry(&geom);
    scene.commit();
    let build_s = start.elapsed().as_secs_f64();

    let closest = |c: &[BenchRay]| {
        let mut ctx = IntersectContext::incoherent();
        let (mut n, mut ts) = (0u64, 0f64);
        for r in c {
            let mut rh = RayHit::from_ray(Ray::segment(r.o.to_array(), r.d.to_array(), 0.0, r.t_max));
            scene.intersect(&mut ctx, &mut rh);
            if rh.hit.is_valid() {
                n += 1;
                ts += rh.ray.tfar as f64;
            }
        }
        (n, ts)
    };
    closest(&bounce[..bounce.len().min(20_000)]);
    let start = Instant::now();
    let parts: Vec<(u64, f64)> = bounce.par_chunks(4096).map(closest).collect();
    let closest_mrays = bounce.len() as f64 / start.elapsed().as_secs_f64() / 1e6;
    let (hits, t_sum) = parts.into_iter().fold((0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));

    let any = |c: &[BenchRay]| {
        let mut ctx = IntersectContext::incoherent();
        c.iter()
            .filter(|r| {
                let mut ray = Ray::segment(r.o.to_array(), r.d.to_array(), 0.0, r.t_max);
                scene.occluded(&mut ctx, &mut ray)
            })
            .count() as u64
    };
    let start = Instant::now();
    let occluded: u64 = shadow.par_chunks(4096).map(any).sum();
    let any_mrays = shadow.len() as f64 / start.elapsed().as_secs_f64() / 1e6;
    Some(TraceResult { build_s, closest_mrays, any_mrays, hits, t_sum, occluded })
}
