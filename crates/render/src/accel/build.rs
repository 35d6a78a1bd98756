//! BVH construction: a binary tree by binned SAH (Wald 2007, "On fast
//! construction of SAH-based bounding volume hierarchies"), built in
//! parallel, then collapsed into wide (8-child) nodes by repeatedly opening the
//! child of largest surface area (as Embree and pbrt's wide BVHs do).

use crate::geometry::Aabb;
use glam::{UVec3, Vec3, Vec3A};
use rayon::prelude::*;

/// What a build primitive refers to. The build itself only tells
/// triangles from the rest: they share 4-wide blocks, the others do not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ItemKind {
    /// Triangle `index` of the mesh with shape id `id`.
    Triangle,
    /// The sphere, disk or cylinder with shape id `id`.
    Shape,
    /// Instance `id`.
    Instance,
}

/// A primitive to build over: its box and reference (36 bytes; the
/// centroid is recomputed from the box, which is cheaper than storing it
/// for ten million primitives).
#[derive(Debug, Clone, Copy)]
pub struct Item {
    /// World-space bounds of the primitive.
    pub bounds: Aabb,
    /// What the primitive is (selects the meaning of `id` and `index`).
    pub kind: ItemKind,
    /// Shape id, or instance id for instances.
    pub id: u32,
    /// Triangle index within the mesh (0 for other kinds).
    pub index: u32,
}

impl Item {
    /// Centre of the bounds, the split key.
    #[inline(always)]
    pub fn centroid(&self) -> Vec3 {
        self.bounds.center()
    }

    /// SAH weight in quarter blocks: a triangle shares a 4-wide SIMD test
    /// with three others, a sphere, disk, cylinder or instance is tested on
    /// its own and costs at least a whole block. Without this, the few
    /// analytic shapes of a Cornell box or a sphere scene land in one leaf
    /// and every ray tests all of them.
    #[inline(always)]
    fn weight(&self) -> u32 {
        match self.kind {
            ItemKind::Triangle => 1,
            ItemKind::Shape | ItemKind::Instance => 4,
        }
    }
}

/// A node of the binary tree; leaves hold a range of the item array, all
/// triangles or none.
pub enum BNode {
    /// A leaf over `count` items from `first`.
    Leaf {
        /// Bounds of the leaf's items.
        bounds: Aabb,
        /// First item of the range.
        first: usize,
        /// Number of items in the range.
        count: usize,
    },
    /// An inner node with two children.
    Inner {
        /// Bounds of both children.
        bounds: Aabb,
        /// The two subtrees.
        children: Box<[BNode; 2]>,
    },
}

impl BNode {
    /// World-space bounds of the node.
    pub fn bounds(&self) -> Aabb {
        match self {
            BNode::Leaf { bounds, .. } | BNode::Inner { bounds, .. } => *bounds,
        }
    }
}

const BINS: usize = 32;
/// Largest leaf: two blocks of four triangles.
pub const MAX_LEAF: usize = 8;
/// SAH cost of one node visit; leaf costs are in these units.
const TRAVERSAL_COST: f32 = 1.0;
/// SAH cost of one 4-wide triangle block where node loads miss the cache
/// (large scenes): incoherent rays wait on memory, so large leaves that
/// save a level pay. On the 1M-triangle traversal benchmark, 1.0 instead
/// of 0.5 lowered closest-hit throughput from 0.84x to 0.75-0.81x of Embree.
const BLOCK_COST_LARGE: f32 = 0.5;
/// The same where the whole tree stays in the cache (small scenes): tests
/// dominate, and a binary split is nearly free once collapsed into an
/// 8-wide node, so walls, spheres and lights get slots of their own. On
/// the Cornell box (16 spp, callgrind) 4.0 instead of 0.5 took 13 % off the
/// instructions of the whole render; 8.0 gave the same tree.
const BLOCK_COST_SMALL: f32 = 4.0;
/// Scenes of at most this many primitives use [`BLOCK_COST_SMALL`]: their
/// tree (about 55 bytes a triangle) fits in a 512 KiB L2 cache.
const SMALL_SCENE: usize = 8192;
/// Subtrees at least this large are built on two threads.
const PARALLEL: usize = 4096;

#[derive(Clone, Copy)]
struct Bins {
    b: [[Aabb; BINS]; 3],
    n: [[u32; BINS]; 3],
}

impl Bins {
    fn empty() -> Bins {
        Bins { b: [[Aabb::EMPTY; BINS]; 3], n: [[0; BINS]; 3] }
    }
    fn merge(mut self, o: Bins) -> Bins {
        for a in 0..3 {
            for i in 0..BINS {
                self.b[a][i] = self.b[a][i].union(o.b[a][i]);
                self.n[a][i] += o.n[a][i];
            }
        }
        self
    }
}

#[inline]
fn bin_of(c: f32, min: f32, scale: f32, bins: usize) -> usize {
    (((c - min) * scale) as usize).min(bins - 1)
}

/// SAH cost of a summed [`Item::weight`]: blocks of four triangles.
#[inline]
fn blocks(w: u32) -> f32 {
    w.div_ceil(4) as f32
}

/// Builds the binary tree over `items`, reordering them into leaf order.
pub fn build_binary(items: &mut [Item]) -> BNode {
    let block_cost = if items.len() <= SMALL_SCENE { BLOCK_COST_SMALL } else { BLOCK_COST_LARGE };
    build_rec(items, 0, block_cost)
}

fn build_rec(items: &mut [Item], first: usize, block_cost: f32) -> BNode {
    let n = items.len();
    // Primitive bounds and centroid bounds in one pass.
    let both =
        |c: &[Item]| c.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, cb), p| (b.union(p.bounds), cb.grow(p.centroid())));
    let join = |a: (Aabb, Aabb), b: (Aabb, Aabb)| (a.0.union(b.0), a.1.union(b.1));
    let (bounds, cb) = if n >= PARALLEL {
        items.par_chunks(4096).map(both).reduce(|| (Aabb::EMPTY, Aabb::EMPTY), join)
    } else {
        both(items)
    };
    let leaf = |items: &mut [Item]| make_leaf(items, first, bounds);
    if n == 1 {
        return leaf(items);
    }
    // Fewer bins for small nodes, as Embree does: there are many of them,
    // and sweeping 32 mostly empty bins costs more than the binning.
    let nb = BINS.min(4 + n / 20);
    let ext = cb.extent();
    let scale = Vec3A::from(Vec3::new(
        if ext.x > 0.0 { nb as f32 / ext.x } else { 0.0 },
        if ext.y > 0.0 { nb as f32 / ext.y } else { 0.0 },
        if ext.z > 0.0 { nb as f32 / ext.z } else { 0.0 },
    ));
    let cmin = Vec3A::from(cb.min);
    let fill = |chunk: &[Item]| {
        let mut bins = Bins::empty();
        for p in chunk {
            let i = ((Vec3A::from(p.centroid()) - cmin) * scale).as_uvec3().min(UVec3::splat(nb as u32 - 1));
            for a in 0..3 {
                let k = i[a] as usize;
                bins.b[a][k] = bins.b[a][k].union(p.bounds);
                bins.n[a][k] += p.weight();
            }
        }
        bins
    };
    let bins =
        if n >= PARALLEL { items.par_chunks(4096).map(fill).reduce(Bins::empty, Bins::merge) } else { fill(items) };

    // Sweep each axis: suffix areas from the right, then prefixes.
    let mut best = (f32::INFINITY, 0usize, 0usize); // (cost, axis, first bin on the right)
    for a in 0..3 {
        if ext[a] <= 0.0 {
            continue;
        }
        let mut right = [(0.0f32, 0u32); BINS];
        let (mut acc_b, mut acc_n) = (Aabb::EMPTY, 0);
        for i in (1..nb).rev() {
            acc_b = acc_b.union(bins.b[a][i]);
            acc_n += bins.n[a][i];
            right[i] = (acc_b.area(), acc_n);
        }
        let (mut left_b, mut left_n) = (Aabb::EMPTY, 0);
        for i in 0..nb - 1 {
            left_b = left_b.union(bins.b[a][i]);
            left_n += bins.n[a][i];
            let (ra, rn) = right[i + 1];
            if left_n == 0 || rn == 0 {
                continue;
            }
            let cost = left_b.area() * blocks(left_n) + ra * blocks(rn);
            if cost < best.0 {
                best = (cost, a, i + 1);
            }
        }
    }

    // Every item is binned once per axis: one axis's counts sum to the total.
    let weight: u32 = bins.n[0][..nb].iter().sum();
    let leaf_cost = block_cost * blocks(weight);
    let split_cost = TRAVERSAL_COST + block_cost * best.0 / bounds.area().max(f32::MIN_POSITIVE);
    let mid = if best.0.is_finite() && (split_cost < leaf_cost || n > MAX_LEAF) {
        let (a, split) = (best.1, best.2);
        partition(items, |p| bin_of(p.centroid()[a], cb.min[a], scale[a], nb) < split)
    } else if n > MAX_LEAF {
        // All centroids coincide: split by count.
        n / 2
    } else {
        return leaf(items);
    };
    let (l, r) = items.split_at_mut(mid);
    let (left, right) = if n >= PARALLEL {
        rayon::join(|| build_rec(l, first, block_cost), || build_rec(r, first + mid, block_cost))
    } else {
        (build_rec(l, first, block_cost), build_rec(r, first + mid, block_cost))
    };
    BNode::Inner { bounds, children: Box::new([left, right]) }
}

/// A leaf, or two when triangles and other primitives meet (a leaf holds
/// triangles only or none).
fn make_leaf(items: &mut [Item], first: usize, bounds: Aabb) -> BNode {
    let tris = partition(items, |p| p.kind == ItemKind::Triangle);
    if tris == 0 || tris == items.len() {
        return BNode::Leaf { bounds, first, count: items.len() };
    }
    let (a, b) = items.split_at(tris);
    let ba = a.iter().fold(Aabb::EMPTY, |x, p| x.union(p.bounds));
    let bb = b.iter().fold(Aabb::EMPTY, |x, p| x.union(p.bounds));
    BNode::Inner {
        bounds,
        children: Box::new([
            BNode::Leaf { bounds: ba, first, count: tris },
            BNode::Leaf { bounds: bb, first: first + tris, count: items.len() - tris },
        ]),
    }
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

/// Up to `width` children for a wide node: starting from `node`'s two, the
/// inner child of largest area is replaced by its own two children.
pub fn wide_children(node: &BNode, width: usize) -> Vec<&BNode> {
    let BNode::Inner { children, .. } = node else { return vec![node] };
    let mut out: Vec<&BNode> = vec![&children[0], &children[1]];
    while out.len() < width {
        let best = out
            .iter()
            .enumerate()
            .filter(|(_, c)| matches!(c, BNode::Inner { .. }))
            .max_by(|a, b| a.1.bounds().area().total_cmp(&b.1.bounds().area()));
        let Some((i, _)) = best else { break };
        let BNode::Inner { children, .. } = out.swap_remove(i) else { unreachable!() };
        out.push(&children[0]);
        out.push(&children[1]);
    }
    out
}
