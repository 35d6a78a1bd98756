//! Embree 3 (Debian's `libembree-dev`, through the `embree3` crate) on the
//! ray-traversal benchmark's triangles and rays: the reference for BVH
//! build time and traversal speed. Compiled only with the `embree` feature.

use super::rays::{BenchRay, Tracer};
use embree3::{BufferUsage, Device, Format, GeometryKind, IntersectContext, Ray, RayHit, Scene};
use penumbra_render::geometry::TriangleMesh;
use std::time::Instant;

/// Embree's scene as a benchmark [`Tracer`].
struct EmbreeTracer<'s, 'd>(&'s Scene<'d>);

impl Tracer for EmbreeTracer<'_, '_> {
    /// `rtcIntersect1` with an incoherent context.
    fn closest(&self, rays: &[BenchRay]) -> (u64, f64) {
        let mut ctx = IntersectContext::incoherent();
        let (mut n, mut ts) = (0u64, 0f64);
        for r in rays {
            let mut rh = RayHit::from_ray(Ray::segment(r.o.to_array(), r.d.to_array(), 0.0, r.t_max));
            self.0.intersect(&mut ctx, &mut rh);
            if rh.hit.is_valid() {
                n += 1;
                ts += rh.ray.tfar as f64;
            }
        }
        (n, ts)
    }
    /// `rtcOccluded1` with an incoherent context.
    fn occluded(&self, rays: &[BenchRay]) -> u64 {
        let mut ctx = IntersectContext::incoherent();
        rays.iter()
            .filter(|r| {
                let mut ray = Ray::segment(r.o.to_array(), r.d.to_array(), 0.0, r.t_max);
                self.0.occluded(&mut ctx, &mut ray)
            })
            .count() as u64
    }
}

/// Builds Embree's BVH (default, medium quality) over the mesh and runs `f`
/// with it and the build time in seconds.
pub fn with_embree<R>(mesh: &TriangleMesh, f: impl FnOnce(&dyn Tracer, f64) -> R) -> Option<R> {
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
    let result = f(&EmbreeTracer(&scene), build_s);
    Some(result)
}
