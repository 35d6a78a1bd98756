//! Mitsuba's `shapegroup` and `instance`: shapes stored once, in object
//! space, with a BVH of their own, and placed any number of times by a
//! transform. The scene's BVH holds each instance as one [`Primitive`];
//! rays entering it are carried into object space (the ray parameter t is
//! unchanged by an affine map, so hits compare across levels) and the hit
//! is carried back.

use super::{Accel, Hit, Primitive};
use crate::geometry::{Aabb, Ray, Shape, SurfaceInteraction};
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::sync::Arc;

/// Shapes of the scene, by id, that only instances place: their geometry
/// (in object space) and materials are the scene's like any shape's, and
/// the group's BVH over them is built once. Queries take the scene's shapes.
#[derive(Debug)]
pub struct ShapeGroup {
    /// The members' shape ids.
    pub members: Vec<u32>,
    /// BVH over the members, in object space.
    pub accel: Accel,
}

impl ShapeGroup {
    /// The group of `shapes[id]` for each id of `members`.
    pub fn new(members: Vec<u32>, shapes: &[Shape]) -> ShapeGroup {
        let prims: Vec<Primitive> = members.iter().map(|&id| Primitive::Shape(id)).collect();
        let accel = Accel::build(&prims, shapes, &[]);
        ShapeGroup { members, accel }
    }
}

/// One placement of a [`ShapeGroup`] by a transform (Mitsuba's `instance`).
#[derive(Debug, Clone)]
pub struct Instance {
    /// The group placed, shared by all its instances.
    pub group: Arc<ShapeGroup>,
    world_from_object: Mat4,
    object_from_world: Mat4,
    /// Inverse transpose of the linear part, for normals.
    normal_m: Mat3,
    bounds: Aabb,
}

impl Instance {
    /// Places `group` by `world_from_object`; the world bounds enclose the
    /// transformed corners of the group's box, padded against rounding.
    pub fn new(group: Arc<ShapeGroup>, world_from_object: Mat4) -> Instance {
        let object_from_world = world_from_object.inverse();
        let normal_m = Mat3::from_mat4(object_from_world).transpose();
        let b = group.accel.bounds;
        let bounds = if b.min.x > b.max.x {
            Aabb::EMPTY
        } else {
            let corners: Vec<Vec3> = (0..8)
                .map(|i| {
                    let c = Vec3::new(
                        if i & 1 == 0 { b.min.x } else { b.max.x },
                        if i & 2 == 0 { b.min.y } else { b.max.y },
                        if i & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    world_from_object.transform_point3(c)
                })
                .collect();
            let w = Aabb::from_points(&corners);
            // Pad by a few ulps against rounding in the transform.
            let pad = Vec3::splat(1e-6 * (w.min.abs().max(w.max.abs()).max_element() + 1.0));
            Aabb { min: w.min - pad, max: w.max + pad }
        };
        Instance { group, world_from_object, object_from_world, normal_m, bounds }
    }

    /// World-space bounds.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    #[inline]
    fn object_ray(&self, ray: &Ray) -> Ray {
        Ray::new(
            self.object_from_world.transform_point3(ray.o),
            self.object_from_world.transform_vector3(ray.d),
            ray.t_max,
        )
    }

    /// Closest hit, with `shape` the id of the member hit (`t` is the world
    /// ray's: the object-space ray keeps its unnormalised direction).
    /// `shapes` are the scene's, which hold the group's members.
    #[inline]
    pub fn intersect(&self, ray: &Ray, shapes: &[Shape]) -> Option<Hit> {
        let r = self.object_ray(ray);
        self.group.accel.intersect(&r, shapes, &[])
    }

    /// Any hit with 0 < t < `ray.t_max` (world ray), for shadow rays.
    #[inline]
    pub fn occluded(&self, ray: &Ray, shapes: &[Shape]) -> bool {
        self.group.accel.occluded(&self.object_ray(ray), shapes, &[])
    }

    /// The interaction, in world space, at a hit on primitive `prim` of
    /// `shape`, the group member with id `shape_id` (arguments as in
    /// [`Shape::interaction_with`], with the world ray).
    #[allow(clippy::too_many_arguments)]
    pub fn interaction_with(
        &self,
        shape: &Shape,
        shape_id: u32,
        prim: usize,
        ray: &Ray,
        t: f32,
        uv: Vec2,
        param: bool,
    ) -> SurfaceInteraction {
        let r = self.object_ray(ray);
        let mut si = shape.interaction_with(shape_id, prim, &r, t, uv, param);
        let m = &self.world_from_object;
        si.p = m.transform_point3(si.p);
        si.n = (self.normal_m * si.n).normalize();
        si.dpdu = m.transform_vector3(si.dpdu);
        si.dpdv = m.transform_vector3(si.dpdv);
        let sh_n = (self.normal_m * si.sh_frame.n).normalize();
        si.sh_frame = SurfaceInteraction::frame_from_dpdu(sh_n, si.dpdu);
        si.wo = -ray.d.normalize();
        si
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, TriangleMesh};
    use crate::sampling::rng::{hash_words, to_unit_f32};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 55, k]))
    }

    /// Instanced geometry answers every query like the same geometry transformed into place.
    #[test]
    fn instances_agree_with_flattened_geometry() {
        let mut cube = TriangleMesh::cube();
        cube.transform(&Mat4::from_scale(Vec3::new(0.5, 0.3, 0.4)));
        let shapes =
            vec![Shape::Mesh(Mesh::new(cube.clone(), false)), Shape::sphere(Vec3::new(1.0, 0.0, 0.0), 0.4, false)];
        let group = Arc::new(ShapeGroup::new(vec![0, 1], &shapes));
        let placements = [
            Mat4::from_translation(Vec3::new(0.0, 0.0, 0.0)),
            Mat4::from_translation(Vec3::new(-2.0, 1.0, 0.5))
                * Mat4::from_rotation_y(0.8)
                * Mat4::from_scale(Vec3::splat(1.5)),
            Mat4::from_translation(Vec3::new(1.5, -1.5, -1.0)) * Mat4::from_rotation_x(-0.5),
        ];
        let instances: Vec<Instance> = placements.iter().map(|m| Instance::new(group.clone(), *m)).collect();
        let placed: Vec<Primitive> = (0..instances.len() as u32).map(Primitive::Instance).collect();
        let mut flat = Vec::new();
        let mut flat_ids = Vec::new();
        for m in &placements {
            let mut c = cube.clone();
            c.transform(m);
            flat.push(Shape::Mesh(Mesh::new(c, false)));
            flat_ids.push(0);
            // The sphere's uv follows its rotated frame, as inside the instance.
            let scale = m.transform_vector3(Vec3::X).length();
            let rot = Mat3::from_mat4(*m) * (1.0 / scale);
            flat.push(Shape::sphere_rotated(m.transform_point3(Vec3::X), 0.4 * scale, rot, false));
            flat_ids.push(1);
        }
        let (a_top, a_flat) = (Accel::build(&placed, &shapes, &instances), Accel::build_shapes(&flat));
        a_top.validate().unwrap();
        let mut hits = 0;
        for i in 0..3000u64 {
            let o = Vec3::new(rnd(i, 0), rnd(i, 1), rnd(i, 2)) * 8.0 - 4.0;
            // Aimed at points around the placements, so most rays hit.
            let target = Vec3::new(rnd(i, 3), rnd(i, 4), rnd(i, 5)) * 4.0 - 2.0;
            let d = (target - o).normalize();
            let ray = Ray::new(o, d, if i % 3 == 0 { 3.0 } else { f32::INFINITY });
            let (h1, h2) = (a_top.intersect(&ray, &shapes, &instances), a_flat.intersect(&ray, &flat, &[]));
            assert_eq!(a_top.occluded(&ray, &shapes, &instances), h2.is_some(), "ray {i}");
            match (h1, h2) {
                (None, None) => {}
                (Some(h1), Some(h2)) => {
                    hits += 1;
                    assert!((h1.t - h2.t).abs() < 1e-4 * h2.t.max(1.0), "ray {i}: {} vs {}", h1.t, h2.t);
                    assert_eq!(h2.instance, Hit::NOT_INSTANCED);
                    let inst = &instances[h1.instance as usize];
                    let member = &shapes[h1.shape as usize];
                    let si1 = inst.interaction_with(member, h1.shape, h1.index as usize, &ray, h1.t, h1.uv, true);
                    let si2 = flat[h2.shape as usize].interaction(0, h2.index as usize, &ray, h2.t, h2.uv);
                    assert_eq!(si1.shape, flat_ids[h2.shape as usize]);
                    assert!((si1.p - si2.p).length() < 1e-4, "ray {i}: p {} vs {}", si1.p, si2.p);
                    assert!((si1.n - si2.n).length() < 1e-4, "ray {i}: n {} vs {}", si1.n, si2.n);
                    assert!((si1.sh_frame.n - si2.sh_frame.n).length() < 1e-4);
                    assert!((si1.uv - si2.uv).length() < 1e-4, "ray {i}: uv {} vs {}", si1.uv, si2.uv);
                    assert!((si1.dpdu - si2.dpdu).length() < 1e-4 * si2.dpdu.length().max(1.0));
                    assert!((si1.sh_frame.s - si2.sh_frame.s).length() < 1e-3, "ray {i}");
                }
                (a, b) => {
                    // Only rays grazing an edge may disagree.
                    let t = a.map(|h| h.t).or(b.map(|h| h.t)).unwrap();
                    panic!("ray {i}: {a:?} vs {b:?} at t {t}");
                }
            }
        }
        assert!(hits > 500, "{hits} hits");
    }
}
