//! The bounding volume hierarchy: 8-wide nodes (one SIMD slab test for all
//! eight child boxes, quantised to bytes) over leaves of 4-triangle blocks tested in SIMD lanes
//! ([`super::tri4`]), built by binned SAH and collapsed from a binary tree
//! ([`super::build`]). Traversal is ordered front to back and skips stacked
//! subtrees that begin beyond the closest hit found so far.

use super::build::{build_binary, wide_children, BNode, Item, ItemKind};
use super::instance::Instance;
use super::lanes8::F8;
use super::memory::HugeArray;
use super::tri4::{intersect4, RayLanes, Tri4};
#[cfg(test)]
use crate::geometry::triangle::intersect_triangle;
use crate::geometry::triangle::RayShear;
use crate::geometry::{Aabb, Ray, Shape};
use glam::{Vec2, Vec3};
use std::mem::MaybeUninit;

/// What a BVH is built over: a shape by its id (a mesh contributes each
/// of its triangles, an analytic shape itself) or an instance by its index.
/// Leaves store the analytic shapes and instances they hold as these too.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    /// `shapes[id]`; in a leaf, a sphere, disk or cylinder, intersected through its shape.
    Shape(u32),
    /// In a leaf: part `index` of the multi-part shape `shapes[id]` (one
    /// ellipsoid, one culled triangle; see [`Shape::is_multi_part`]).
    Part(u32, u32),
    /// `instances[i]`: a shape group (a BVH of its own, in object space) placed by a transform.
    Instance(u32),
}

/// Children per node. Incoherent rays are bound by the latency of each
/// level's node load, so a wide, shallow tree pays: going from 4 to 8
/// children raised closest-hit throughput from 0.65-0.72x of Embree's to
/// about 0.8x (`penumbra bench --suite rays`, 1M triangles).
pub(super) const WIDTH: usize = 8;

/// A wide node: the children's boxes quantised to bytes on a per-axis grid
/// (plane = origin + q·scale, as in Ylitie et al. 2017 and Embree's
/// quantised BVH), rounded outwards, so every box tested contains the true
/// one and the traversal stays conservative. 128 bytes, two cache lines
/// instead of four with f32 planes: incoherent rays are bound by the
/// latency of node loads. Measured against f32 nodes (`bench --suite rays`,
/// 1M triangles, three alternating runs): closest hit 0.81-0.85x of Embree
/// against 0.79-0.81x, any hit 0.89-0.99x against 0.77-0.90x, and 54.6
/// instead of 61.1 bytes per triangle.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Node {
    pub(super) origin: [f32; 3],
    pub(super) scale: [f32; 3],
    /// Rows: min x, max x, min y, max y, min z, max z.
    pub(super) q: [[u8; WIDTH]; 6],
    pub(super) child: [u32; WIDTH],
    /// See [`OTHER`].
    pub(super) info: [u8; WIDTH],
    /// Bit `l` set where slot `l` holds a child.
    pub(super) used: u8,
}

/// `info` of a child slot: 0 for an inner node (`child` is its index), the
/// number of triangle blocks for a triangle leaf (`child` is the first
/// block), or `OTHER | count` for a leaf of analytic shapes and instances
/// (`child` is the first index into `prims`). Leaves hold at most
/// `MAX_LEAF` items, so counts fit beside the flag in a byte.
pub(super) const OTHER: u32 = 0x80;

impl Node {
    /// Quantises the boxes of up to `WIDTH` children.
    fn new(boxes: &[Aabb], child: [u32; WIDTH], info: [u8; WIDTH]) -> Node {
        debug_assert!(!boxes.is_empty() && boxes.len() <= WIDTH);
        let mut n = Node {
            origin: [0.0; 3],
            scale: [0.0; 3],
            // Unused slots keep an inverted box; `used` masks them anyway.
            q: [[255; WIDTH], [0; WIDTH], [255; WIDTH], [0; WIDTH], [255; WIDTH], [0; WIDTH]],
            child,
            info,
            used: ((1u32 << boxes.len()) - 1) as u8,
        };
        let k = boxes.len();
        for a in 0..3 {
            let (mut lo, mut hi) = ([0.0f32; WIDTH], [0.0f32; WIDTH]);
            for (l, b) in boxes.iter().enumerate() {
                (lo[l], hi[l]) = (b.min[a], b.max[a]);
            }
            let [ql, qh] = n.q.get_disjoint_mut([2 * a, 2 * a + 1]).unwrap();
            (n.origin[a], n.scale[a]) = quantize_axis(&lo[..k], &hi[..k], &mut ql[..k], &mut qh[..k]);
        }
        n
    }

    /// The box of slot `l` as the traversal tests it (None for an empty slot).
    fn lane_box(&self, l: usize) -> Option<Aabb> {
        if self.used & (1 << l) == 0 {
            return None;
        }
        let plane = |row: usize, a: usize| dequantize(self.q[row][l], self.scale[a], self.origin[a]);
        Some(Aabb {
            min: Vec3::new(plane(0, 0), plane(2, 1), plane(4, 2)),
            max: Vec3::new(plane(1, 0), plane(3, 1), plane(5, 2)),
        })
    }
}

/// A quantised plane as the traversal computes it ([`F8::mul_add`]: one rounding).
#[inline]
pub(super) fn dequantize(q: u8, scale: f32, origin: f32) -> f32 {
    f32::from(q).mul_add(scale, origin)
}

/// The hit of `ray` on one analytic shape or instance of a leaf, the test
/// both the single-ray and the packet traversal run. `ANY`: an instance
/// only answers whether it blocks the ray (the hit's fields other than `t`
/// are then meaningless).
#[inline(always)]
pub(super) fn prim_hit<const ANY: bool>(
    prim: Primitive,
    ray: &Ray,
    shapes: &[Shape],
    instances: &[Instance],
) -> Option<Hit> {
    match prim {
        Primitive::Shape(shape) => shapes[shape as usize].intersect_analytic(ray).map(|(t, uv)| Hit {
            t,
            uv,
            shape,
            index: 0,
            instance: Hit::NOT_INSTANCED,
        }),
        Primitive::Part(shape, index) => shapes[shape as usize]
            .intersect_prim(index as usize, ray)
            .map(|(t, uv)| Hit { t, uv, shape, index, instance: Hit::NOT_INSTANCED }),
        Primitive::Instance(i) => {
            let inst = &instances[i as usize];
            if ANY {
                inst.occluded(ray, shapes).then_some(Hit {
                    t: ray.t_max,
                    uv: Vec2::ZERO,
                    shape: 0,
                    index: 0,
                    instance: i,
                })
            } else {
                inst.intersect(ray, shapes).map(|h| Hit { instance: i, ..h })
            }
        }
    }
}

/// The grid of one axis, (origin, scale), and the byte planes `ql`, `qh` of
/// `lo` and `hi` (the lanes' minima and maxima): dequantised, every lower
/// plane is <= its `lo` and every upper plane >= its `hi`, checked with the
/// traversal's arithmetic.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn quantize_axis(lo: &[f32], hi: &[f32], ql: &mut [u8], qh: &mut [u8]) -> (f32, f32) {
    let origin = lo.iter().copied().fold(f32::INFINITY, f32::min);
    let top = hi.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    debug_assert!(origin.is_finite() && top.is_finite(), "BVH boxes must be finite");
    // The smallest scale whose top plane (q = 255) reaches `top`; a flat
    // axis gets any positive scale (q = 0 gives `origin` exactly).
    let mut scale = ((top as f64 - origin as f64) / 255.0) as f32;
    if !(scale > 0.0) {
        scale = f32::MIN_POSITIVE;
    }
    while dequantize(255, scale, origin) < top {
        scale = scale.next_up();
    }
    let grid = |v: f32| (v as f64 - origin as f64) / scale as f64;
    for (q, &v) in ql.iter_mut().zip(lo) {
        *q = grid(v).floor().clamp(0.0, 255.0) as u8;
        while *q > 0 && dequantize(*q, scale, origin) > v {
            *q -= 1;
        }
    }
    for (q, &v) in qh.iter_mut().zip(hi) {
        *q = grid(v).ceil().clamp(0.0, 255.0) as u8;
        while dequantize(*q, scale, origin) < v {
            *q += 1;
        }
    }
    (origin, scale)
}

/// A stacked subtree and the distance at which the ray enters its box.
#[derive(Clone, Copy)]
struct Entry {
    child: u32,
    info: u32,
    t: f32,
}

/// The closest hit found by [`Accel::intersect`].
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the (world) ray's `d`.
    pub t: f32,
    /// Triangle barycentrics (b1, b2) or the analytic shape's local coordinates.
    pub uv: Vec2,
    /// The id of the shape hit (inside an instance: the group member's).
    pub shape: u32,
    /// The triangle index within the mesh (0 for analytic shapes).
    pub index: u32,
    /// The index of the instance hit, or [`Hit::NOT_INSTANCED`] for a shape placed directly.
    pub instance: u32,
}

impl Hit {
    /// [`Hit::instance`] of a hit outside every instance.
    pub const NOT_INSTANCED: u32 = u32::MAX;

    /// Whether this hit wins over `best`: nearer, or at exactly the same
    /// distance with a lower (instance, shape, index). Both traversals keep
    /// the least hit in this order, so a ray's hit does not depend on the
    /// order in which leaves are visited (coplanar shapes and the shared
    /// edges of triangles tie at equal `t`).
    #[inline(always)]
    pub fn beats(&self, best: &Option<Hit>) -> bool {
        match best {
            None => true,
            Some(b) => {
                self.t < b.t
                    || (self.t == b.t && (self.instance, self.shape, self.index) < (b.instance, b.shape, b.index))
            }
        }
    }
}

/// The distance up to which a traversal keeps testing once it has a hit at
/// `t`, never beyond the ray's own `t_max`: a few ulps past `t`, so that
/// every primitive hit at `t` or nearer passes the range test (the
/// triangle test checks its range before dividing, with its own rounding)
/// and [`Hit::beats`] decides among them.
#[inline(always)]
pub(super) fn search_limit(t: f32, t_max: f32) -> f32 {
    // t > 0 and finite: adding to the bits steps up by ulps.
    f32::from_bits(t.to_bits() + 16).min(t_max)
}

/// An 8-wide BVH over [`Primitive`]s, built by [`Accel::build`]; the
/// default value is the empty tree, which nothing hits.
#[derive(Debug, Clone, Default)]
pub struct Accel {
    pub(super) nodes: HugeArray<Node>,
    pub(super) tris: HugeArray<Tri4>,
    /// (shape id, triangle index) of each lane of `tris`.
    pub(super) tri_ids: HugeArray<[[u32; 2]; 4]>,
    /// The analytic shapes and instances of the leaves, in leaf order.
    pub prims: Vec<Primitive>,
    /// The root slot, `None` when there is nothing to hit.
    pub(super) root: Option<(u32, u32)>,
    /// Bounds of everything in the tree, in the space of its primitives
    /// (world space; object space for a [`ShapeGroup`](super::ShapeGroup)'s).
    pub bounds: Aabb,
    /// Whether traversal prefetches children: only where the tree is too
    /// large for the L2 cache (in it, prefetching costs instructions and
    /// saves no wait).
    prefetch: bool,
}

/// Trees of more bytes than this are prefetched during traversal.
const PREFETCH_BYTES: usize = 256 << 10;

pub(super) const STACK: usize = 192;

/// The arrays of a tree being written out in place, sized beforehand by
/// [`count_wide`], with how many of each are written so far.
struct Emitter {
    nodes: HugeArray<Node>,
    tris: HugeArray<Tri4>,
    tri_ids: HugeArray<[[u32; 2]; 4]>,
    prims: Vec<Primitive>,
    n_nodes: usize,
    n_blocks: usize,
}

/// (wide nodes, triangle blocks) the tree below `node` emits.
fn count_wide(node: &BNode, items: &[Item]) -> (usize, usize) {
    match node {
        BNode::Leaf { first, count, .. } if items[*first].kind == ItemKind::Triangle => (0, count.div_ceil(4)),
        BNode::Leaf { .. } => (0, 0),
        BNode::Inner { .. } => wide_children(node, WIDTH).iter().fold((1, 0), |(n, b), k| {
            let (kn, kb) = count_wide(k, items);
            (n + kn, b + kb)
        }),
    }
}

impl Emitter {
    /// Appends `node` in wide form; returns its slot (child, info).
    fn emit(&mut self, node: &BNode, items: &[Item], shapes: &[Shape]) -> (u32, u32) {
        match node {
            BNode::Leaf { first, count, .. } => {
                let leaf = &items[*first..*first + *count];
                if leaf[0].kind == ItemKind::Triangle {
                    let start = self.n_blocks as u32;
                    for block in leaf.chunks(4) {
                        let mut verts = [[Vec3::ZERO; 3]; 4];
                        let mut ids = [[u32::MAX; 2]; 4];
                        for (l, p) in block.iter().enumerate() {
                            let Shape::Mesh(m) = &shapes[p.id as usize] else {
                                unreachable!("triangle items come from meshes")
                            };
                            verts[l] = m.vertices(p.index as usize);
                            ids[l] = [p.id, p.index];
                        }
                        self.tris[self.n_blocks] = Tri4::new(&verts[..block.len()]);
                        self.tri_ids[self.n_blocks] = ids;
                        self.n_blocks += 1;
                    }
                    (start, self.n_blocks as u32 - start)
                } else {
                    let start = self.prims.len() as u32;
                    for p in leaf {
                        self.prims.push(match p.kind {
                            ItemKind::Instance => Primitive::Instance(p.id),
                            ItemKind::Shape if shapes[p.id as usize].is_multi_part() => Primitive::Part(p.id, p.index),
                            ItemKind::Shape | ItemKind::Triangle => Primitive::Shape(p.id),
                        });
                    }
                    (start, OTHER | leaf.len() as u32)
                }
            }
            BNode::Inner { .. } => {
                let kids = wide_children(node, WIDTH);
                let idx = self.n_nodes;
                self.n_nodes += 1;
                let (mut child, mut info) = ([0u32; WIDTH], [0u8; WIDTH]);
                for (l, k) in kids.iter().enumerate() {
                    let (c, i) = self.emit(k, items, shapes);
                    assert!(i < 0x100, "a leaf holds at most MAX_LEAF items");
                    (child[l], info[l]) = (c, i as u8);
                }
                let mut boxes = [Aabb::EMPTY; WIDTH];
                for (b, k) in boxes.iter_mut().zip(&kids) {
                    *b = k.bounds();
                }
                self.nodes[idx] = Node::new(&boxes[..kids.len()], child, info);
                (idx as u32, 0)
            }
        }
    }
}

impl Accel {
    /// Builds the BVH over every shape of `shapes`, each placed as it is.
    pub fn build_shapes(shapes: &[Shape]) -> Accel {
        let prims: Vec<Primitive> = (0..shapes.len() as u32).map(Primitive::Shape).collect();
        Accel::build(&prims, shapes, &[])
    }

    /// Builds the BVH over `prims`, which refer to `shapes` and `instances`
    /// (shapes that no primitive names, such as the members of shape
    /// groups, stay out of it). Queries take the same two slices.
    pub fn build(prims: &[Primitive], shapes: &[Shape], instances: &[Instance]) -> Accel {
        let mut items = Vec::new();
        for &prim in prims {
            match prim {
                Primitive::Shape(id) => match &shapes[id as usize] {
                    Shape::Mesh(m) => {
                        items.reserve(m.mesh.indices.len());
                        for i in 0..m.mesh.indices.len() {
                            let v = m.vertices(i);
                            // Degenerate triangles can never be hit; leave them out.
                            if (v[1] - v[0]).cross(v[2] - v[0]).length_squared() == 0.0 {
                                continue;
                            }
                            let b = Aabb::from_points(&v);
                            items.push(Item { bounds: b, kind: ItemKind::Triangle, id, index: i as u32 });
                        }
                    }
                    shape if shape.is_multi_part() => {
                        items.reserve(shape.prim_count());
                        for i in 0..shape.prim_count() {
                            let b = shape.prim_bounds(i);
                            // Empty parts (degenerate triangles) can never be hit.
                            if b.min.x <= b.max.x {
                                items.push(Item { bounds: b, kind: ItemKind::Shape, id, index: i as u32 });
                            }
                        }
                    }
                    shape => items.push(Item { bounds: shape.prim_bounds(0), kind: ItemKind::Shape, id, index: 0 }),
                },
                Primitive::Part(..) => unreachable!("parts are placed by their shape"),
                Primitive::Instance(id) => {
                    let b = instances[id as usize].bounds();
                    if b.min.x <= b.max.x {
                        items.push(Item { bounds: b, kind: ItemKind::Instance, id, index: 0 });
                    }
                }
            }
        }
        if items.is_empty() {
            return Accel::default();
        }
        let tree = build_binary(&mut items);
        let (n_nodes, n_blocks) = count_wide(&tree, &items);
        // SAFETY: nodes, triangle blocks and ids are plain floats and integers.
        let mut out = unsafe {
            Emitter {
                nodes: HugeArray::zeroed(n_nodes),
                tris: HugeArray::zeroed(n_blocks),
                tri_ids: HugeArray::zeroed(n_blocks),
                prims: Vec::new(),
                n_nodes: 0,
                n_blocks: 0,
            }
        };
        let root = out.emit(&tree, &items, shapes);
        debug_assert_eq!((out.n_nodes, out.n_blocks), (n_nodes, n_blocks));
        let prefetch = std::mem::size_of_val(&out.nodes[..]) + std::mem::size_of_val(&out.tris[..]) > PREFETCH_BYTES;
        Accel {
            nodes: out.nodes,
            tris: out.tris,
            tri_ids: out.tri_ids,
            prims: out.prims,
            root: Some(root),
            bounds: tree.bounds(),
            prefetch,
        }
    }

    /// Closest hit with 0 < t < ray.t_max, given the shapes and instances
    /// the tree was built over; of hits at equal t, the least by
    /// [`Hit::beats`].
    #[inline]
    pub fn intersect(&self, ray: &Ray, shapes: &[Shape], instances: &[Instance]) -> Option<Hit> {
        let root = self.root?;
        let shear = RayShear::new(ray.d);
        match shear.kz {
            0 => self.traverse::<0, false>(ray, &shear, ray.d.recip(), root, shapes, instances),
            1 => self.traverse::<1, false>(ray, &shear, ray.d.recip(), root, shapes, instances),
            _ => self.traverse::<2, false>(ray, &shear, ray.d.recip(), root, shapes, instances),
        }
    }

    /// Whether anything blocks the ray before `ray.t_max`.
    #[inline]
    pub fn occluded(&self, ray: &Ray, shapes: &[Shape], instances: &[Instance]) -> bool {
        let Some(root) = self.root else { return false };
        let shear = RayShear::new(ray.d);
        match shear.kz {
            0 => self.traverse::<0, true>(ray, &shear, ray.d.recip(), root, shapes, instances),
            1 => self.traverse::<1, true>(ray, &shear, ray.d.recip(), root, shapes, instances),
            _ => self.traverse::<2, true>(ray, &shear, ray.d.recip(), root, shapes, instances),
        }
        .is_some()
    }

    /// The single-ray walk of the subtree of slot `start` (child, info),
    /// for the packet traversal's rays left alone in a subtree; `shear`
    /// and `inv_d` are `RayShear::new(ray.d)` and `ray.d.recip()`, which
    /// the packet has in its lanes. Kept out of line, where LLVM kept it
    /// before it took these arguments: the packet loop need not grow by a
    /// copy of the single-ray walk per dominant axis for its rare handoffs.
    #[inline(never)]
    pub(super) fn traverse_slot<const ANY: bool>(
        &self,
        ray: &Ray,
        shear: &RayShear,
        inv_d: Vec3,
        start: (u32, u32),
        shapes: &[Shape],
        instances: &[Instance],
    ) -> Option<Hit> {
        debug_assert_eq!(inv_d.to_array().map(f32::to_bits), ray.d.recip().to_array().map(f32::to_bits));
        match shear.kz {
            0 => self.traverse::<0, ANY>(ray, shear, inv_d, start, shapes, instances),
            1 => self.traverse::<1, ANY>(ray, shear, inv_d, start, shapes, instances),
            _ => self.traverse::<2, ANY>(ray, shear, inv_d, start, shapes, instances),
        }
    }

    /// Walks the subtree of slot `start` (the root for a whole query).
    /// `ANY`: stop at the first hit (its fields other than `t` are then
    /// meaningless).
    #[inline(always)]
    fn traverse<const KZ: usize, const ANY: bool>(
        &self,
        ray: &Ray,
        shear: &RayShear,
        inv_d: Vec3,
        (root_child, root_info): (u32, u32),
        shapes: &[Shape],
        instances: &[Instance],
    ) -> Option<Hit> {
        let mut ray = *ray;
        // `ray.t_max` becomes the search limit; hits stay below this.
        let t_max = ray.t_max;
        let o = [F8::splat(ray.o.x), F8::splat(ray.o.y), F8::splat(ray.o.z)];
        let id = [F8::splat(inv_d.x), F8::splat(inv_d.y), F8::splat(inv_d.z)];
        // Lane rows of the near and far planes per axis, by direction sign.
        let neg = [(inv_d.x < 0.0) as usize, (inv_d.y < 0.0) as usize, (inv_d.z < 0.0) as usize];
        let near = [neg[0], 2 + neg[1], 4 + neg[2]];
        let far = [1 - neg[0], 3 - neg[1], 5 - neg[2]];
        let lanes = RayLanes::new(&ray, shear);
        // Robust traversal (Ize 2013): widen the exit distance by gamma(3).
        let widen = F8::splat(1.0 + 2.0 * 3.0 * f32::EPSILON);
        let mut best: Option<Hit> = None;
        // Left uninitialised: entries are written before they are read.
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut sp = 0usize;
        let mut cur = Entry { child: root_child, info: root_info, t: 0.0 };
        loop {
            if cur.info == 0 {
                let node = &self.nodes[cur.child as usize];
                let plane = |row: usize, a: usize| {
                    F8::from_u8(&node.q[row]).mul_add(F8::splat(node.scale[a]), F8::splat(node.origin[a]))
                };
                let slab = |row: usize, a: usize| plane(row, a).sub(o[a]).mul(id[a]);
                let t0 = slab(near[0], 0).max(slab(near[1], 1));
                let t0 = t0.max(slab(near[2], 2).max(F8::splat(0.0)));
                let t1 = slab(far[0], 0).min(slab(far[1], 1));
                let t1 = t1.min(slab(far[2], 2).min(F8::splat(ray.t_max)));
                let mut mask = t0.le_mask(t1.mul(widen)) & node.used as u32;
                if mask != 0 {
                    // Incoherent rays are bound by memory latency: start
                    // loading every child that will be visited now, so the
                    // misses overlap instead of following one another.
                    let mut m = if self.prefetch { mask } else { 0 };
                    while m != 0 {
                        let l = m.trailing_zeros() as usize;
                        m &= m - 1;
                        self.prefetch(node.child[l], node.info[l] as u32);
                    }
                    let tn = t0.to_array();
                    if mask & (mask - 1) == 0 {
                        let l = mask.trailing_zeros() as usize;
                        cur = Entry { child: node.child[l], info: node.info[l] as u32, t: tn[l] };
                        continue;
                    }
                    // Several children: push them, sorted in place far to
                    // near (insertion among the new entries), then pop the
                    // nearest to visit it.
                    let base = sp;
                    while mask != 0 {
                        let l = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let e = Entry { child: node.child[l], info: node.info[l] as u32, t: tn[l] };
                        if sp == STACK {
                            debug_assert!(false, "BVH traversal stack overflow");
                            break;
                        }
                        let mut k = sp;
                        // SAFETY: stack[base..sp] were written in this loop.
                        while !ANY && k > base && unsafe { stack[k - 1].assume_init() }.t < e.t {
                            stack[k] = stack[k - 1];
                            k -= 1;
                        }
                        stack[k].write(e);
                        sp += 1;
                    }
                    sp -= 1;
                    // SAFETY: stack[..sp] are written (entries pushed above, or
                    // older ones if the stack was full).
                    cur = unsafe { stack[sp].assume_init() };
                    continue;
                }
            } else if cur.info & OTHER == 0 {
                for blk in cur.child..cur.child + cur.info {
                    let (mut mask, t, b1, b2) = intersect4::<KZ>(&lanes, ray.t_max, &self.tris[blk as usize]);
                    if mask != 0 {
                        if ANY {
                            return Some(Hit {
                                t: ray.t_max,
                                uv: Vec2::ZERO,
                                shape: 0,
                                index: 0,
                                instance: Hit::NOT_INSTANCED,
                            });
                        }
                        let (t, b1, b2) = (t.to_array(), b1.to_array(), b2.to_array());
                        while mask != 0 {
                            let l = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let [shape, index] = self.tri_ids[blk as usize][l];
                            let h = Hit {
                                t: t[l],
                                uv: Vec2::new(b1[l], b2[l]),
                                shape,
                                index,
                                instance: Hit::NOT_INSTANCED,
                            };
                            if h.beats(&best) {
                                ray.t_max = search_limit(h.t, t_max);
                                best = Some(h);
                            }
                        }
                    }
                }
            } else {
                let first = cur.child as usize;
                for prim in &self.prims[first..first + (cur.info & !OTHER) as usize] {
                    if let Some(h) = prim_hit::<ANY>(*prim, &ray, shapes, instances) {
                        if ANY {
                            return Some(h);
                        }
                        if h.beats(&best) {
                            ray.t_max = search_limit(h.t, t_max);
                            best = Some(h);
                        }
                    }
                }
            }
            // Pop the next subtree that still starts before the closest hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: stack[..sp] were all written by the push above.
                let e = unsafe { stack[sp].assume_init() };
                if ANY || e.t <= ray.t_max {
                    cur = e;
                    break;
                }
            }
        }
    }

    /// Hints the memory of a child slot into the cache.
    #[inline(always)]
    fn prefetch(&self, child: u32, info: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (p, len) = if info == 0 {
                (self.nodes.as_ptr().wrapping_add(child as usize) as *const i8, std::mem::size_of::<Node>())
            } else if info & OTHER == 0 {
                // Every block of the leaf: they are all tested.
                (
                    self.tris.as_ptr().wrapping_add(child as usize) as *const i8,
                    info as usize * std::mem::size_of::<Tri4>(),
                )
            } else {
                return;
            };
            // SAFETY: prefetching has no side effects, even off an allocation.
            unsafe {
                let mut off = 0;
                while off < len {
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off));
                    off += 64;
                }
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(len - 1));
            }
        }
    }

    /// Checks the structural invariants (children inside parents, every
    /// triangle and primitive in exactly one leaf). Used by tests.
    pub fn validate(&self) -> Result<(), String> {
        let Some(root) = self.root else { return Ok(()) };
        let mut seen_blocks = vec![0u8; self.tris.len()];
        let mut seen_prims = vec![0u8; self.prims.len()];
        self.validate_slot(root, None, &mut seen_blocks, &mut seen_prims, 0)?;
        if seen_blocks.iter().chain(&seen_prims).any(|&c| c != 1) {
            return Err("a leaf entry is not referenced exactly once".into());
        }
        Ok(())
    }

    fn validate_slot(
        &self,
        (child, info): (u32, u32),
        bounds: Option<Aabb>,
        blocks: &mut [u8],
        prims: &mut [u8],
        depth: usize,
    ) -> Result<(), String> {
        if depth > 64 {
            return Err("tree too deep".into());
        }
        if info == 0 {
            // Each primitive must lie inside the (quantised) box of every
            // ancestor slot: `bounds` is their intersection. (A child's own
            // quantised boxes may stick out of its parent's: each node
            // rounds outwards on its own grid.)
            let n = &self.nodes[child as usize];
            for l in 0..WIDTH {
                let Some(b) = n.lane_box(l) else { continue };
                if b.is_empty() {
                    return Err(format!("node {child} lane {l} has an empty box"));
                }
                let b = match bounds {
                    Some(p) => Aabb { min: p.min.max(b.min), max: p.max.min(b.max) },
                    None => b,
                };
                self.validate_slot((n.child[l], n.info[l] as u32), Some(b), blocks, prims, depth + 1)?;
            }
        } else if info & OTHER == 0 {
            for k in child..child + info {
                blocks[k as usize] += 1;
                let tri = &self.tris[k as usize];
                for l in 0..tri.len() {
                    if let Some(p) = bounds {
                        if !p.contains_box(&Aabb::from_points(&tri.lane(l))) {
                            return Err(format!("triangle block {k} lane {l} is outside its leaf"));
                        }
                    }
                }
            }
        } else {
            for k in child..child + (info & !OTHER) {
                prims[k as usize] += 1;
            }
        }
        Ok(())
    }

    /// (wide nodes, triangle blocks, average child slots used per node).
    pub fn stats(&self) -> (usize, usize, f64) {
        let used: usize = self.nodes.iter().map(|n| n.used.count_ones() as usize).sum();
        (self.nodes.len(), self.tris.len(), used as f64 / self.nodes.len().max(1) as f64)
    }

    /// Number of triangles stored (for tests and statistics).
    pub fn triangle_count(&self) -> usize {
        self.tris.iter().map(|t| t.len()).sum()
    }

    /// Bytes held by the hierarchy (nodes, triangle blocks, ids, primitives).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(&self.nodes[..])
            + std::mem::size_of_val(&self.tris[..])
            + std::mem::size_of_val(&self.tri_ids[..])
            + self.prims.capacity() * std::mem::size_of::<Primitive>()
    }
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

    /// Both SAH cost regimes: a scene small enough to stay in the cache,
    /// and one above `build::SMALL_SCENE` primitives.
    #[test]
    fn bvh_agrees_with_brute_force() {
        for n in [2000, 12000] {
            agrees_with_brute_force(n);
        }
    }

    fn agrees_with_brute_force(n: usize) {
        let shapes = random_soup(n);
        let accel = Accel::build_shapes(&shapes);
        accel.validate().unwrap();
        assert_eq!(accel.triangle_count(), n);
        for i in 0..2000u64 {
            let o = Vec3::new(rnd(i, 100), rnd(i, 101), rnd(i, 102)) * 12.0 - 1.0;
            let d = (Vec3::new(rnd(i, 103), rnd(i, 104), rnd(i, 105)) - 0.5).normalize();
            let ray = Ray::new(o, d, if i % 3 == 0 { 4.0 } else { f32::INFINITY });
            let shear = RayShear::new(d);
            let mut brute = f32::INFINITY;
            let Shape::Mesh(m) = &shapes[0] else { unreachable!() };
            for k in 0..m.mesh.indices.len() {
                if let Some(h) = intersect_triangle(&ray, &shear, &m.vertices(k)) {
                    brute = brute.min(h.0);
                }
            }
            if let Some(h) = shapes[1].intersect_analytic(&ray) {
                brute = brute.min(h.0);
            }
            let hit = accel.intersect(&ray, &shapes, &[]);
            assert_eq!(hit.map(|h| h.t), brute.is_finite().then_some(brute), "ray {i}");
            assert_eq!(accel.occluded(&ray, &shapes, &[]), brute.is_finite(), "ray {i}");
        }
    }

    /// Multi-part shapes (an ellipsoid cloud, culled shells, an SDF grid,
    /// curves): each part is
    /// a primitive of its own, and the BVH finds the closest part a brute
    /// force over all parts finds (culled back faces included).
    #[test]
    fn multi_part_shapes_agree_with_brute_force() {
        use crate::geometry::ellipsoids::quat_to_matrix;
        use crate::geometry::{Ellipsoid, Ellipsoids, Shell};
        let ellipsoid = |i: u64| {
            let q = glam::DVec4::new(rnd(i, 7) as f64, rnd(i, 8) as f64 - 0.5, 0.3, 0.8).normalize();
            Ellipsoid {
                center: Vec3::new(rnd(i, 1), rnd(i, 2), rnd(i, 3)) * 10.0,
                scale: Vec3::new(0.2 + rnd(i, 4), 0.2 + rnd(i, 5), 0.2 + rnd(i, 6)),
                rot: quat_to_matrix(q.to_array()).as_mat3(),
            }
        };
        let cloud: Vec<Ellipsoid> = (0..300).map(ellipsoid).collect();
        let shells: Vec<Ellipsoid> = (300..500).map(ellipsoid).collect();
        // 200 random control points; every fifth segment left out.
        let curves = |basis| {
            let points = (0..200)
                .map(|k| glam::Vec4::new(rnd(k, 60) * 10.0, rnd(k, 61) * 10.0, rnd(k, 62) * 10.0, 0.3 * rnd(k, 63)));
            Shape::Curves(crate::geometry::Curves {
                points: points.collect(),
                segments: (0..196).filter(|k| k % 5 != 4).collect(),
                basis,
            })
        };
        let sdf = crate::accel::packet::tests::sdf_blob(glam::DMat4::from_translation(glam::DVec3::new(4.0, 4.0, 4.0)));
        let voxels = sdf.voxel_count();
        let shapes = vec![
            Shape::Ellipsoids(Ellipsoids { items: cloud }),
            Shape::CulledMesh(Mesh::new(Shell::IcoSphere.mesh(&shells), true)),
            Shape::SdfGrid(sdf),
            curves(crate::geometry::curves::Basis::Linear),
            curves(crate::geometry::curves::Basis::BSpline),
        ];
        let accel = Accel::build_shapes(&shapes);
        accel.validate().unwrap();
        assert_eq!(accel.prims.len(), 300 + 200 * 20 + voxels + 2 * 157);
        let mut hits = 0;
        for i in 0..3000u64 {
            let o = Vec3::new(rnd(i, 100), rnd(i, 101), rnd(i, 102)) * 12.0 - 1.0;
            let d = (Vec3::new(rnd(i, 103), rnd(i, 104), rnd(i, 105)) - 0.5).normalize();
            let ray = Ray::new(o, d, if i % 3 == 0 { 4.0 } else { f32::INFINITY });
            let mut brute: Option<(f32, u32, u32)> = None;
            for (id, s) in shapes.iter().enumerate() {
                for k in 0..s.prim_count() {
                    if let Some((t, _)) = s.intersect_prim(k, &ray) {
                        if brute.is_none_or(|b| t < b.0) {
                            brute = Some((t, id as u32, k as u32));
                        }
                    }
                }
            }
            let hit = accel.intersect(&ray, &shapes, &[]);
            assert_eq!(hit.map(|h| h.t), brute.map(|b| b.0), "ray {i}");
            if let (Some(h), Some(b)) = (hit, brute) {
                let again = shapes[h.shape as usize].intersect_prim(h.index as usize, &ray).map(|x| x.0);
                assert_eq!(again, Some(b.0), "ray {i}: the hit's part does not give its t");
                hits += 1;
            }
            assert_eq!(accel.occluded(&ray, &shapes, &[]), brute.is_some(), "ray {i}");
        }
        assert!(hits > 800, "{hits}");
    }

    /// Separate spheres each get a leaf (a slot) of their own, so a ray
    /// tests only those whose boxes it crosses; counted as one triangle
    /// each, four of them would share one leaf.
    #[test]
    fn analytic_shapes_get_leaves_of_their_own() {
        let shapes: Vec<Shape> =
            (0..4).map(|k| Shape::sphere(Vec3::new(3.0 * k as f32, 0.0, 0.0), 1.0, false)).collect();
        let accel = Accel::build_shapes(&shapes);
        accel.validate().unwrap();
        let mut leaves = Vec::new();
        let mut todo = vec![accel.root.unwrap()];
        while let Some((child, info)) = todo.pop() {
            if info == 0 {
                let node = &accel.nodes[child as usize];
                todo.extend(
                    (0..WIDTH).filter(|l| node.used & (1 << l) != 0).map(|l| (node.child[l], node.info[l] as u32)),
                );
            } else {
                leaves.push(info & !OTHER);
            }
        }
        assert_eq!(leaves, [1, 1, 1, 1]);
    }

    #[test]
    fn empty_scene_hits_nothing() {
        let accel = Accel::build_shapes(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        assert!(accel.intersect(&ray, &[], &[]).is_none());
        assert!(!accel.occluded(&ray, &[], &[]));
    }
}
