//! Embree 3 (Debian's `libembree-dev`, through the `embree3` crate) on the
//! ray-traversal benchmark's triangles and rays: the reference for BVH
//! build time and traversal speed. Compiled only with the `embree` feature.

use super::rays::Tracer;
use embree3::{BufferUsage, Device, Format, GeometryKind, IntersectContext, Ray, RayHit, Scene};
use glam::Vec3;
use penumbra_render::accel::Primitive;
use penumbra_render::geometry::{Ray as PenumbraRay, Shape, TriangleMesh};
use std::time::Instant;

/// Embree's scene as a benchmark [`Tracer`].
struct EmbreeTracer<'s, 'd>(&'s Scene<'d>);

impl Tracer for EmbreeTracer<'_, '_> {
    /// `rtcIntersect1` with an incoherent context.
    fn closest(&self, rays: &[PenumbraRay]) -> (u64, f64) {
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
    fn occluded(&self, rays: &[PenumbraRay]) -> u64 {
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
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    with_geometry(&positions, &mesh.indices, &[], f)
}

/// Segments per disk: a disk becomes a fan of this many triangles.
const DISK_SEGMENTS: u32 = 256;

/// Embree over a scene's placed primitives (`placed`, naming `shapes`):
/// meshes as triangles, spheres as Embree's sphere points, disks as fine
/// triangle fans. Cylinders and instances have no counterpart here; they
/// return an error naming them.
pub fn with_embree_shapes<R>(
    placed: &[Primitive],
    shapes: &[Shape],
    f: impl FnOnce(&dyn Tracer) -> R,
) -> Result<R, String> {
    let (mut positions, mut indices, mut spheres) = (Vec::<[f32; 3]>::new(), Vec::<[u32; 3]>::new(), Vec::new());
    for prim in placed {
        let shape = match *prim {
            Primitive::Shape(id) => &shapes[id as usize],
            Primitive::Instance(_) => return Err("an instance has no Embree counterpart here".into()),
            Primitive::Part(..) => return Err("a multi-part shape has no Embree counterpart here".into()),
        };
        let base = positions.len() as u32;
        match shape {
            Shape::Mesh(m) => {
                positions.extend(m.mesh.positions.iter().map(|p| p.to_array()));
                indices.extend(m.mesh.indices.iter().map(|t| t.map(|i| i + base)));
            }
            Shape::Sphere(s) => spheres.push([s.center.x, s.center.y, s.center.z, s.radius]),
            Shape::Disk(d) => {
                let world_from_object = &d.world_from_object;
                positions.push(world_from_object.transform_point3(Vec3::ZERO).to_array());
                for k in 0..DISK_SEGMENTS {
                    let phi = std::f32::consts::TAU * k as f32 / DISK_SEGMENTS as f32;
                    let p = Vec3::new(phi.cos(), phi.sin(), 0.0);
                    positions.push(world_from_object.transform_point3(p).to_array());
                    indices.push([base, base + 1 + k, base + 1 + (k + 1) % DISK_SEGMENTS]);
                }
            }
            Shape::Cylinder(_) => return Err("a cylinder has no Embree counterpart here".into()),
            Shape::Ellipsoids(_) | Shape::CulledMesh(_) | Shape::SdfGrid(_) | Shape::Curves(_) => {
                return Err("ellipsoids, SDF grids and curves have no Embree counterpart here".into())
            }
        }
    }
    with_geometry(&positions, &indices, &spheres, |t, _| f(t)).ok_or_else(|| "Embree's device failed".into())
}

/// Builds an Embree scene of triangles and spheres ([x, y, z, radius]).
fn with_geometry<R>(
    positions: &[[f32; 3]],
    indices: &[[u32; 3]],
    spheres: &[[f32; 4]],
    f: impl FnOnce(&dyn Tracer, f64) -> R,
) -> Option<R> {
    let device = match Device::new() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("note: Embree device failed: {e:?}");
            return None;
        }
    };
    let start = Instant::now();
    let mut scene = device.create_scene().ok()?;
    let mut committed = Vec::new();
    if !indices.is_empty() {
        let mut geom = device.create_geometry(GeometryKind::TRIANGLE).ok()?;
        geom.set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, positions.len())
            .ok()?
            .copy_from_slice(positions);
        geom.set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, indices.len())
            .ok()?
            .copy_from_slice(indices);
        committed.push(geom.commit());
    }
    if !spheres.is_empty() {
        let mut geom = device.create_geometry(GeometryKind::SPHERE_POINT).ok()?;
        geom.set_new_buffer::<[f32; 4]>(BufferUsage::VERTEX, 0, Format::FLOAT4, 16, spheres.len())
            .ok()?
            .copy_from_slice(spheres);
        committed.push(geom.commit());
    }
    for g in &committed {
        scene.attach_geometry(g);
    }
    scene.commit();
    let build_s = start.elapsed().as_secs_f64();
    let result = f(&EmbreeTracer(&scene), build_s);
    Some(result)
}
