//! Bounding volume hierarchy: binned surface-area-heuristic build (Wald 2007,
//! "On fast construction of SAH-based bounding volume hierarchies"), flattened
//! depth-first into 32-byte nodes with the left child stored next to its
//! parent, and front-to-back ordered traversal.

#[cfg(test)]
use crate::geometry::triangle::intersect_triangle;
use crate::geometry::triangle::{intersect_triangle_k, RayShear};
use crate::geometry::{Aabb, Ray, Shape};
use glam::{Vec2, Vec3, Vec3A, Vec4};

/// A primitive as stored in BVH order. Triangles keep their vertices inline
/// so traversal touches one cache line per test.
#[derive(Debug, Clone, Copy)]
pub enum Prim {
    Triangle {
        v: [Vec3; 3],
        shape: u32,
        index: u32,
    },
    /// A sphere, disk or cylinder, intersected through its shape.
    Analytic {
        shape: u32,
    },
    /// An instance of a shape group (a BVH of its own, in object space).
    Instance {
        shape: u32,
    },
}

impl Prim {
    #[inline]
    pub fn shape(&self) -> u32 {
        match *self {
            Prim::Triangle { shape, .. } | Prim::Analytic { shape } | Prim::Instance { shape } => shape,
        }
    }
    /// Index of the primitive within its shape (triangle index; 0 otherwise).
    #[inline]
    pub fn index(&self) -> u32 {
        match *self {
            Prim::Triangle { index, .. } => index,
            Prim::Analytic { .. } | Prim::Instance { .. } => 0,
        }
    }
}

/// A flattened node. Interior: `offset` is the right child (the left child
/// is the next node), `count` = 0, `axis` the split axis. Leaf: `offset` is
/// the first primitive, `count` how many.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Node {
    min: [f32; 3],
    offset: u32,
    max: [f32; 3],
    count: u16,
    axis: u16,
}

impl Node {
    /// The box corners as SIMD vectors (one 16-byte load each; the fourth
    /// lane holds `offset` / `count` bits and is ignored).
    #[inline(always)]
    fn corners(&self) -> (Vec3A, Vec3A) {
        // SAFETY: Node is repr(C) and 32-byte aligned: min + offset and
        // max + count + axis are each 16 contiguous, aligned bytes.
        let (lo, hi) = unsafe {
            let p = self as *const Node as *const Vec4;
            (*p, *p.add(1))
        };
        (Vec3A::from_vec4(lo), Vec3A::from_vec4(hi))
    }
}

/// The closest hit found by [`Accel::intersect`].
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    pub t: f32,
    /// Index into [`Accel::prims`].
    pub prim: u32,
    /// Triangle barycentrics (b1, b2) or the analytic shape's local coordinates.
    pub uv: Vec2,
    /// The primitive within its shape: the triangle index (0 for analytic
    /// shapes), or for an instance the index into its group's BVH primitives.
    pub index: u32,
}

#[derive(Debug, Clone, Default)]
pub struct Accel {
    nodes: Vec<Node>,
    pub prims: Vec<Prim>,
    pub bounds: Aabb,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 8;
const TRAVERSAL_COST: f32 = 1.0;
const INTERSECT_COST: f32 = 1.0;
const STACK: usize = 64;

struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    prim: Prim,
}

impl Accel {
    /// Builds the BVH over every primitive of every shape.
    pub fn build(shapes: &[Shape]) -> Accel {
        let mut items = Vec::new();
        for (si, shape) in shapes.iter().enumerate() {
            match shape {
                Shape::Mesh(m) => {
                    for i in 0..m.mesh.indices.len() {
                        let v = m.vertices(i);
                        let b = Aabb::from_points(&v);
                        // Degenerate triangles can never be hit; leave them out.
                        if (v[1] - v[0]).cross(v[2] - v[0]).length_squared() == 0.0 {
                            continue;
                        }
                        items.push(BuildPrim {
                            bounds: b,
                            centroid: b.center(),
                            prim: Prim::Triangle { v, shape: si as u32, index: i as u32 },
                        });
                    }
                }
                Shape::GroupMember => {}
                Shape::Instance(i) => {
                    let b = i.bounds();
                    if b.min.x <= b.max.x {
                        items.push(BuildPrim {
                            bounds: b,
                            centroid: b.center(),
                            prim: Prim::Instance { shape: si as u32 },
                        });
                    }
                }
                _ => {
                    let b = shape.prim_bounds(0);
                    items.push(BuildPrim {
                        bounds: b,
                        centroid: b.center(),
                        prim: Prim::Analytic { shape: si as u32 },
                    });
                }
            }
        }
        let mut nodes = Vec::with_capacity(2 * items.len() / 2 + 1);
        if !items.is_empty() {
            build_recursive(&mut items, 0, &mut nodes);
        }
        let bounds = items.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
        Accel { nodes, prims: items.into_iter().map(|p| p.prim).collect(), bounds }
    }

    /// Closest hit with 0 < t < ray.t_max.
    #[inline]
    pub fn intersect(&self, ray: &Ray, shapes: &[Shape]) -> Option<Hit> {
        let mut ray = *ray;
        let mut best: Option<Hit> = None;
        self.traverse(&mut ray, shapes, false, |ray, prim, t, uv, index| {
            ray.t_max = t;
            best = Some(Hit { t, prim, uv, index });
            false
        });
        best
    }

    /// Whether anything blocks the ray before `ray.t_max`.
    #[inline]
    pub fn occluded(&self, ray: &Ray, shapes: &[Shape]) -> bool {
        let mut ray = *ray;
        let mut hit = false;
        self.traverse(&mut ray, shapes, true, |_, _, _, _, _| {
            hit = true;
            true
        });
        hit
    }

    /// Walks the tree; `on_hit` returns true to stop (any-hit queries).
    #[inline(always)]
    fn traverse(
        &self,
        ray: &mut Ray,
        shapes: &[Shape],
        any_hit: bool,
        on_hit: impl FnMut(&mut Ray, u32, f32, Vec2, u32) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let shear = RayShear::new(ray.d);
        match shear.kz {
            0 => self.traverse_k::<0>(ray, &shear, shapes, any_hit, on_hit),
            1 => self.traverse_k::<1>(ray, &shear, shapes, any_hit, on_hit),
            _ => self.traverse_k::<2>(ray, &shear, shapes, any_hit, on_hit),
        }
    }

    #[inline(always)]
    fn traverse_k<const KZ: usize>(
        &self,
        ray: &mut Ray,
        shear: &RayShear,
        shapes: &[Shape],
        any_hit: bool,
        mut on_hit: impl FnMut(&mut Ray, u32, f32, Vec2, u32) -> bool,
    ) {
        let inv_d = Vec3A::from(ray.d.recip());
        let o = Vec3A::from(ray.o);
        let neg = [inv_d.x < 0.0, inv_d.y < 0.0, inv_d.z < 0.0];
        // Left uninitialised: entries are written before they are read, and
        // zeroing 256 bytes per ray showed up in profiles.
        let mut stack = [std::mem::MaybeUninit::<u32>::uninit(); STACK];
        let mut sp = 0usize;
        let mut idx = 0usize;
        loop {
            let node = &self.nodes[idx];
            if slab_test(node, o, inv_d, ray.t_max) {
                if node.count > 0 {
                    let first = node.offset as usize;
                    for (k, prim) in self.prims[first..first + node.count as usize].iter().enumerate() {
                        let found = match prim {
                            Prim::Triangle { v, index, .. } => intersect_triangle_k::<KZ>(ray, shear, v)
                                .map(|(t, b1, b2)| (t, Vec2::new(b1, b2), *index)),
                            Prim::Analytic { shape } => {
                                shapes[*shape as usize].intersect_analytic(ray).map(|(t, uv)| (t, uv, 0))
                            }
                            Prim::Instance { shape } => {
                                let Shape::Instance(inst) = &shapes[*shape as usize] else { unreachable!() };
                                if any_hit {
                                    // Any hit will do: report t_max itself (never read).
                                    inst.occluded(ray).then_some((ray.t_max, Vec2::ZERO, 0))
                                } else {
                                    inst.intersect(ray)
                                }
                            }
                        };
                        if let Some((t, uv, index)) = found {
                            if on_hit(ray, (first + k) as u32, t, uv, index) {
                                return;
                            }
                        }
                    }
                } else {
                    // Visit the child on the ray's near side first.
                    let (near, far) = if neg[node.axis as usize] {
                        (node.offset as usize, idx + 1)
                    } else {
                        (idx + 1, node.offset as usize)
                    };
                    if sp < STACK {
                        stack[sp].write(far as u32);
                        sp += 1;
                    }
                    idx = near;
                    continue;
                }
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            // SAFETY: stack[..sp] were all written by the push above.
            idx = unsafe { stack[sp].assume_init() } as usize;
        }
    }

    /// Checks the structural invariants (children inside parents, every
    /// primitive in exactly one leaf). Used by tests.
    pub fn validate(&self) -> Result<(), String> {
        let mut seen = vec![0u8; self.prims.len()];
        if !self.nodes.is_empty() {
            self.validate_node(0, None, &mut seen, 0)?;
        }
        if seen.iter().any(|&c| c != 1) {
            return Err("a primitive is not referenced exactly once".into());
        }
        Ok(())
    }

    fn validate_node(&self, idx: usize, parent: Option<Aabb>, seen: &mut [u8], depth: usize) -> Result<(), String> {
        let n = &self.nodes[idx];
        let b = Aabb { min: Vec3::from(n.min), max: Vec3::from(n.max) };
        if let Some(p) = parent {
            if !p.contains_box(&b) {
                return Err(format!("node {idx} is not inside its parent"));
            }
        }
        if depth >= STACK {
            return Err("tree deeper than the traversal stack".into());
        }
        if n.count > 0 {
            for i in n.offset as usize..n.offset as usize + n.count as usize {
                seen[i] += 1;
            }
            Ok(())
        } else {
            self.validate_node(idx + 1, Some(b), seen, depth + 1)?;
            self.validate_node(n.offset as usize, Some(b), seen, depth + 1)
        }
    }
}

#[inline(always)]
fn slab_test(node: &Node, o: Vec3A, inv_d: Vec3A, t_max: f32) -> bool {
    let (lo, hi) = node.corners();
    let t0 = (lo - o) * inv_d;
    let t1 = (hi - o) * inv_d;
    let tmin = t0.min(t1).max_element().max(0.0);
    let tmax = t0.max(t1).min_element().min(t_max);
    // Slightly widen the exit distance so rays grazing a box's face still
    // visit it (robust traversal: Ize 2013, gamma(3) factor).
    tmin <= tmax * (1.0 + 2.0 * 3.0 * f32::EPSILON)
}

fn build_recursive(items: &mut [BuildPrim], first: usize, nodes: &mut Vec<Node>) -> usize {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    let idx = nodes.len();
    nodes.push(Node { min: bounds.min.into(), offset: first as u32, max: bounds.max.into(), count: 0, axis: 0 });
    let n = items.len();
    let make_leaf = |nodes: &mut Vec<Node>| {
        nodes[idx].count = n as u16;
        nodes[idx].offset = first as u32;
        idx
    };
    if n == 1 {
        return make_leaf(nodes);
    }
    let cb = items.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    let ext = cb.extent();

    // Binned SAH over all three axes.
    let mut best = (f32::INFINITY, 0usize, 0usize); // (cost, axis, split bin)
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext[axis];
        let mut bin_b = [Aabb::EMPTY; BINS];
        let mut bin_n = [0usize; BINS];
        for p in items.iter() {
            let b = (((p.centroid[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
            bin_b[b] = bin_b[b].union(p.bounds);
            bin_n[b] += 1;
        }
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_n = [0usize; BINS];
        let (mut acc_b, mut acc_n) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc_b = acc_b.union(bin_b[i]);
            acc_n += bin_n[i];
            right_area[i] = acc_b.area();
            right_n[i] = acc_n;
        }
        let (mut left_b, mut left_n) = (Aabb::EMPTY, 0);
        for i in 0..BINS - 1 {
            left_b = left_b.union(bin_b[i]);
            left_n += bin_n[i];
            if left_n == 0 || right_n[i + 1] == 0 {
                continue;
            }
            let cost = left_b.area() * left_n as f32 + right_area[i + 1] * right_n[i + 1] as f32;
            if cost < best.0 {
                best = (cost, axis, i + 1);
            }
        }
    }

    let leaf_cost = INTERSECT_COST * n as f32;
    let split_cost = if best.0.is_finite() {
        TRAVERSAL_COST + INTERSECT_COST * best.0 / bounds.area().max(f32::MIN_POSITIVE)
    } else {
        f32::INFINITY
    };
    let mid = if best.0.is_finite() && (split_cost < leaf_cost || n > MAX_LEAF) {
        let (axis, split) = (best.1, best.2);
        let scale = BINS as f32 / ext[axis];
        partition(items, |p| ((((p.centroid[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1)) < split)
    } else if n > MAX_LEAF {
        // All centroids coincide: split by count.
        n / 2
    } else {
        return make_leaf(nodes);
    };
    let axis = if best.0.is_finite() { best.1 } else { ext.max_position() };
    let (left, right) = items.split_at_mut(mid);
    build_recursive(left, first, nodes);
    let right_idx = build_recursive(right, first + mid, nodes);
    nodes[idx].offset = right_idx as u32;
    nodes[idx].axis = axis as u16;
    idx
}

fn partition<T>(items: &mut [T], pred: impl Fn(&T) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, TriangleMesh};
    use crate::sampling::rng::{hash_words, to_unit_f32};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, k]))
    }

    fn random_soup(n: usize) -> Vec<Shape> {
        let mut m = TriangleMesh::default();
        for i in 0..n as u64 {
            let c = Vec3::new(rnd(i, 0), rnd(i, 1), rnd(i, 2)) * 10.0;
            for k in 0..3 {
                m.positions.push(c + Vec3::new(rnd(i, 3 + 3 * k), rnd(i, 4 + 3 * k), rnd(i, 5 + 3 * k)) - 0.5);
            }
            let b = 3 * i as u32;
            m.indices.push([b, b + 1, b + 2]);
        }
        vec![Shape::Mesh(Mesh::new(m, false)), Shape::sphere(Vec3::splat(5.0), 1.0, false)]
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let shapes = random_soup(2000);
        let accel = Accel::build(&shapes);
        accel.validate().unwrap();
        for i in 0..2000u64 {
            let o = Vec3::new(rnd(i, 100), rnd(i, 101), rnd(i, 102)) * 12.0 - 1.0;
            let d = (Vec3::new(rnd(i, 103), rnd(i, 104), rnd(i, 105)) - 0.5).normalize();
            let ray = Ray::new(o, d, if i % 3 == 0 { 4.0 } else { f32::INFINITY });
            let shear = RayShear::new(d);
            let mut brute = f32::INFINITY;
            for p in &accel.prims {
                let t = match p {
                    Prim::Triangle { v, .. } => intersect_triangle(&ray, &shear, v).map(|h| h.0),
                    Prim::Analytic { shape } | Prim::Instance { shape } => {
                        shapes[*shape as usize].intersect_analytic(&ray).map(|h| h.0)
                    }
                };
                if let Some(t) = t {
                    brute = brute.min(t);
                }
            }
            let hit = accel.intersect(&ray, &shapes);
            assert_eq!(hit.map(|h| h.t), brute.is_finite().then_some(brute), "ray {i}");
            assert_eq!(accel.occluded(&ray, &shapes), brute.is_finite(), "ray {i}");
        }
    }

    #[test]
    fn empty_scene_hits_nothing() {
        let accel = Accel::build(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        assert!(accel.intersect(&ray, &[]).is_none());
        assert!(!accel.occluded(&ray, &[]));
    }
}
