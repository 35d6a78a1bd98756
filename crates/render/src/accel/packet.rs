//! Packet traversal: up to [`MAX_PACKET`] rays walk the 8-wide BVH of
//! [`super::bvh`] together, one node load shared by all of them.
//!
//! At an inner node each child box is tested against every ray of the
//! packet at once, the rays in the SIMD lanes of a [`Float`] (`F32x8`,
//! `F32x16`, or `f32` one ray at a time). Each lane performs exactly the
//! single-ray box test's operations ([`Accel::intersect`]: the dequantised
//! plane, `(plane - o) * inv_d`, `maxps`/`minps` in the same order, the exit
//! distance widened by gamma(3)), so a ray enters a box here exactly where
//! it would enter it alone with the same `t_max`. A stack entry carries the
//! mask of the rays that entered the child and their entry distances;
//! popped, it keeps the rays whose entry distance is still <= their closest
//! hit, the single-ray rule applied per ray. Children are visited front to
//! back by the entry distance of the lowest ray that enters them. A
//! subtree that at most `FEW_RAYS` (1) rays still enter is handed to the
//! single-ray kernel a ray at a time ([`Accel::intersect`]'s walk, started
//! at that subtree with the ray's closest hit so far as its `t_max`), which
//! tests its boxes for one ray eight at a time instead of eight boxes one
//! at a time.
//!
//! Triangle blocks reached by several active rays are tested a triangle
//! at a time against all rays in lanes (`RayTri`: the lane form of the
//! watertight test, bitwise the scalar one per lane, each ray's dominant
//! axis picked per lane); reached by one ray, with the single-ray
//! [`intersect4`]. Either way a ray's hit in a block is the nearest, the
//! lowest lane among equal distances, as for a single ray. A sphere
//! or disk reached by several active rays is tested against all of them at
//! once (`sphere_hit`, `disk_hit`: [`Sphere::intersect`] and
//! [`Disk::intersect`] per lane). Other leaves are tested
//! one active ray at a time with the single-ray code:
//! [`Shape::intersect_analytic`] for analytic shapes, and
//! [`Instance::intersect`] / [`Instance::occluded`] for instances, which so
//! fall back to single rays per lane (their own BVHs are walked by the
//! single-ray kernel).
//!
//! **Agreement with the single-ray kernel.** Both traversals are
//! conservative (a box whose primitives a ray hits before its search limit
//! is entered) and keep, of all hits, the least by [`Hit::beats`]: the
//! nearest, and among hits at exactly the same `t` (coplanar shapes, or a
//! ray through an edge or vertex shared by two triangles, which the
//! watertight test hits on both sides) the lowest (instance, shape,
//! index). Once a ray has a hit at `t`, its search limit is a few ulps past
//! `t` (`search_limit`), so every primitive hit at `t` or nearer still
//! passes its range test wherever it is visited (the triangle test checks
//! its range before dividing, with its own rounding). The hit of every ray
//! (t, uv, shape, index, instance, bit for bit) and `occluded` are
//! therefore the single-ray ones, whatever order the leaves are visited
//! in; the tests check both kernels against every primitive tested alone.

use super::bvh::{dequantize, prim_hit, search_limit, Accel, Hit, Primitive, OTHER, STACK};
use super::instance::Instance;
use super::tri4::{intersect4, RayLanes};
use crate::geometry::triangle::RayShear;
use crate::geometry::{Disk, Ray, Shape, Sphere};
use crate::simd::{Float, Mask, V3};
use glam::{Vec2, Vec3, Vec4};
use std::mem::MaybeUninit;

/// Active rays from which a triangle block is tested a triangle against
/// all rays at once rather than a ray against its four triangles.
const LANE_TRIANGLES: u32 = 2;

/// Active rays up to which a subtree is walked by the single-ray kernel,
/// one ray after another, rather than as a packet. Once that kernel's
/// set-up no longer waited on its divisions, 1 was fastest (one thread, 4
/// alternating rounds): many_lights (a hundred shapes) 1.02 s with 4, 1.00
/// s with 2, 0.99-1.00 s with 1, and Mitsuba's `cbox.xml` (a BVH of 38
/// triangles) 1.04-1.08 s, 1.03-1.05 s, 1.03-1.04 s; 8 was slower on both.
/// (Before, 4 had been 1.5 % faster than 1 on many_lights.) The small
/// bench scenes have no inner node below the root.
const FEW_RAYS: u32 = 1;

/// Most rays in one packet (the widest [`Float`], `F32x16`).
pub const MAX_PACKET: usize = 16;

/// A stacked subtree with the rays that enter it and where each enters it.
#[derive(Clone, Copy)]
struct Entry<F> {
    child: u32,
    info: u32,
    /// Bit `r` set for ray `r` entering the subtree.
    mask: u32,
    /// Entry distance per ray (meaningful where `mask` is set).
    t0: F,
    /// Sort key: the entry distance of the lowest ray of `mask`.
    key: f32,
}

/// Per-ray state of a packet in lanes.
struct Lanes<F: Float> {
    o: [F; 3],
    d: [F; 3],
    inv_d: [F; 3],
    /// Lanes whose direction component is negative, per axis (the single-ray
    /// kernel's `neg`: near and far planes swap there).
    neg: [F::Mask; 3],
}

impl<F: Float> Lanes<F> {
    fn new(rays: &[Ray]) -> Lanes<F> {
        let mut o = [F::Array::default(); 3];
        let mut d = [F::Array::default(); 3];
        for l in 0..F::WIDTH {
            // Padding lanes repeat the first ray; they are never active.
            let r = rays.get(l).unwrap_or(&rays[0]);
            for a in 0..3 {
                o[a].as_mut()[l] = r.o[a];
                d[a].as_mut()[l] = r.d[a];
            }
        }
        let d = d.map(F::from_array);
        // glam's `recip`: 1 / x per component, exact in lanes too.
        let inv_d = d.map(|x| F::splat(1.0) / x);
        let zero = F::splat(0.0);
        Lanes { o: o.map(F::from_array), d, inv_d, neg: inv_d.map(|v| v.cmp_lt(zero)) }
    }
}

/// [`Sphere::intersect`] of every ray of a packet, each lane performing the
/// scalar test's operations in glam's order: the mask of lanes hit with
/// 0 < t < `t_max`, and their distances.
#[inline(always)]
fn sphere_hit<F: Float>(lanes: &Lanes<F>, s: &Sphere, t_max: F) -> (u32, F) {
    let zero = F::splat(0.0);
    let (o, d) = (V3::new(lanes.o[0], lanes.o[1], lanes.o[2]), V3::new(lanes.d[0], lanes.d[1], lanes.d[2]));
    let f = o - V3::splat(s.center);
    let a = d.dot(d);
    let b = -f.dot(d);
    let l = f + d * (b / a);
    let r2 = F::splat(s.radius * s.radius);
    let disc = a * (r2 - l.dot(l));
    let sq = disc.sqrt();
    let q = F::select(b.cmp_gt(zero), b + sq, b - sq);
    let (t0, t1) = (q / a, f.dot(f).mul_add(F::splat(1.0), -r2) / q);
    let swap = t0.cmp_gt(t1);
    let (t0, t1) = (F::select(swap, t1, t0), F::select(swap, t0, t1));
    let t = F::select(t0.cmp_gt(zero), t0, t1);
    let hit = !disc.cmp_lt(zero) & t.cmp_gt(zero) & t.cmp_lt(t_max);
    (hit.bitmask(), t)
}

/// [`Disk::intersect`] of every ray of a packet, each lane performing the
/// scalar test's operations: glam's `transform_point3` and
/// `transform_vector3` (column products summed in column order, then the
/// translation; no fused multiply-add), `t = -o.z / d.z`, the hit point
/// `o + t d`. The mask of lanes hit with 0 < t < `t_max` inside the unit
/// disk, their distances and local (x, y) (the hit's uv).
#[inline(always)]
fn disk_hit<F: Float>(lanes: &Lanes<F>, disk: &Disk, t_max: F) -> (u32, F, F, F) {
    let m = disk.object_from_world();
    let (cx, cy, cz, cw) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
    let column_sum = |c: usize, v: &[F; 3]| {
        let res = F::splat(cx[c]) * v[0];
        let res = F::splat(cy[c]) * v[1] + res;
        F::splat(cz[c]) * v[2] + res
    };
    let o: [F; 3] = std::array::from_fn(|c| F::splat(cw[c]) + column_sum(c, &lanes.o));
    let d: [F; 3] = std::array::from_fn(|c| column_sum(c, &lanes.d));
    let t = -o[2] / d[2];
    let zero = F::splat(0.0);
    let (px, py) = (o[0] + t * d[0], o[1] + t * d[1]);
    let inside = (px * px + py * py).cmp_le(F::splat(1.0));
    ((t.cmp_gt(zero) & t.cmp_lt(t_max) & inside).bitmask(), t, px, py)
}

/// The single-ray triangle-test constants of one ray.
struct Single {
    lanes: RayLanes,
    kz: usize,
}

#[inline(always)]
fn tri_hit(s: &Single, t_max: f32, tri: &super::tri4::Tri4) -> (u32, Vec4, Vec4, Vec4) {
    match s.kz {
        0 => intersect4::<0>(&s.lanes, t_max, tri),
        1 => intersect4::<1>(&s.lanes, t_max, tri),
        _ => intersect4::<2>(&s.lanes, t_max, tri),
    }
}

/// One triangle against every ray of a packet: the ray-lane form of
/// [`intersect4`] (the watertight test of Woop et al. 2013), each lane
/// performing the scalar test's operations in its order, with the ray's own
/// dominant axis chosen per lane by selects, so each lane's answer is
/// bitwise the single-ray one.
struct RayTri<F: Float> {
    /// The origin permuted to (kx, ky, kz) per lane.
    o: [F; 3],
    /// Shear constants (sx, sy, sz) per lane.
    s: [F; 3],
    /// Per permuted axis: lanes where it is x, lanes where it is y (else z).
    axis: [[F::Mask; 2]; 3],
}

impl<F: Float> RayTri<F> {
    /// The constants of the rays in `l`, in lanes: [`RayShear::new`]'s
    /// comparisons, divisions and axis permutation per lane, selected.
    #[inline(always)]
    fn new(l: &Lanes<F>) -> RayTri<F> {
        let [dx, dy, dz] = l.d;
        let [ox, oy, oz] = l.o;
        let (ax, ay, az) = (dx.abs(), dy.abs(), dz.abs());
        // kz: x where |x| > |y| and |x| > |z|, else y where |y| > |z|, else z.
        let x_gt_y = ax.cmp_gt(ay);
        let kz0 = x_gt_y & ax.cmp_gt(az);
        let kz1 = !x_gt_y & ay.cmp_gt(az);
        let kz2 = !(kz0 | kz1);
        // Component kz, kx = kz + 1 and ky = kz + 2 (mod 3) of (x, y, z).
        let pick = |x: F, y: F, z: F, k: usize| match k {
            0 => F::select(kz0, x, F::select(kz1, y, z)),
            1 => F::select(kz0, y, F::select(kz1, z, x)),
            _ => F::select(kz0, z, F::select(kz1, x, y)),
        };
        let d_z = pick(dx, dy, dz, 0);
        let s = [-pick(dx, dy, dz, 1) / d_z, -pick(dx, dy, dz, 2) / d_z, F::splat(1.0) / d_z];
        let o = [pick(ox, oy, oz, 1), pick(ox, oy, oz, 2), pick(ox, oy, oz, 0)];
        // Lanes where permuted axis kx, ky, kz is x, and where it is y.
        let axis = [[kz2, kz0], [kz1, kz2], [kz0, kz1]];
        RayTri { o, s, axis }
    }

    /// Hits of triangle `v` (`v[vertex][coordinate]`) with 0 < t < `t_max`
    /// per lane: the mask of lanes hit, distances and barycentrics (b1, b2).
    #[inline(always)]
    fn hit(&self, v: &[[f32; 3]; 3], t_max: F) -> (u32, F, F, F) {
        let zero = F::splat(0.0);
        let coord = |k: usize, a: usize| {
            let [x, y] = self.axis[a];
            F::select(x, F::splat(v[k][0]), F::select(y, F::splat(v[k][1]), F::splat(v[k][2]))) - self.o[a]
        };
        let p = |k: usize| {
            let z = coord(k, 2);
            (coord(k, 0) + self.s[0] * z, coord(k, 1) + self.s[1] * z, z)
        };
        let (p0x, p0y, p0z) = p(0);
        let (p1x, p1y, p1z) = p(1);
        let (p2x, p2y, p2z) = p(2);
        let mut e0 = p1x * p2y - p1y * p2x;
        let mut e1 = p2x * p0y - p2y * p0x;
        let mut e2 = p0x * p1y - p0y * p1x;
        let exact = (e0.cmp_eq(zero) | e1.cmp_eq(zero) | e2.cmp_eq(zero)).bitmask();
        if exact != 0 {
            // Rare: an edge function is exactly zero; redo those lanes in f64.
            let (mut a0, mut a1, mut a2) = (e0.to_array(), e1.to_array(), e2.to_array());
            let (x0, y0, x1, y1, x2, y2) =
                (p0x.to_array(), p0y.to_array(), p1x.to_array(), p1y.to_array(), p2x.to_array(), p2y.to_array());
            let (x0, y0, x1, y1, x2, y2) =
                (x0.as_ref(), y0.as_ref(), x1.as_ref(), y1.as_ref(), x2.as_ref(), y2.as_ref());
            for l in 0..F::WIDTH {
                if exact & (1 << l) != 0 {
                    a0.as_mut()[l] = (x1[l] as f64 * y2[l] as f64 - y1[l] as f64 * x2[l] as f64) as f32;
                    a1.as_mut()[l] = (x2[l] as f64 * y0[l] as f64 - y2[l] as f64 * x0[l] as f64) as f32;
                    a2.as_mut()[l] = (x0[l] as f64 * y1[l] as f64 - y0[l] as f64 * x1[l] as f64) as f32;
                }
            }
            (e0, e1, e2) = (F::from_array(a0), F::from_array(a1), F::from_array(a2));
        }
        let any_neg = e0.cmp_lt(zero) | e1.cmp_lt(zero) | e2.cmp_lt(zero);
        let any_pos = e0.cmp_gt(zero) | e1.cmp_gt(zero) | e2.cmp_gt(zero);
        let det = e0 + e1 + e2;
        let t_scaled = (e0 * p0z + e1 * p1z + e2 * p2z) * self.s[2];
        let tmax_det = t_max * det;
        let neg_ok = det.cmp_lt(zero) & !(t_scaled.cmp_ge(zero) | t_scaled.cmp_lt(tmax_det));
        let pos_ok = det.cmp_gt(zero) & !(t_scaled.cmp_le(zero) | t_scaled.cmp_gt(tmax_det));
        let valid = !(any_neg & any_pos) & (neg_ok | pos_ok);
        if !valid.any() {
            return (0, zero, zero, zero);
        }
        let inv_det = F::splat(1.0) / det;
        let t = t_scaled * inv_det;
        let valid = valid & t.cmp_gt(zero) & t.cmp_lt(t_max);
        (valid.bitmask(), t, e1 * inv_det, e2 * inv_det)
    }
}

/// Ray `r`'s `RayShear::new(d)`, which [`RayTri::new`] forms in lanes:
/// the single-ray kernel's set-up, for the rays a packet hands to it.
#[inline(always)]
fn lane_shear<F: Float>(ray_tri: &RayTri<F>, r: usize) -> RayShear {
    // Lanes where the dominant axis (permuted axis kz) is x, and where it is y.
    let [kz0, kz1] = ray_tri.axis[2];
    let kz = if kz0.bitmask() >> r & 1 != 0 {
        0
    } else if kz1.bitmask() >> r & 1 != 0 {
        1
    } else {
        2
    };
    let [sx, sy, sz] = ray_tri.s.map(|s| s.to_array().as_ref()[r]);
    RayShear { kz, sx, sy, sz }
}

/// Ray `r`'s `d.recip()`, which [`Lanes::new`] forms in lanes.
#[inline(always)]
fn lane_inv_d<F: Float>(lanes: &Lanes<F>, r: usize) -> Vec3 {
    Vec3::from_array(lanes.inv_d.map(|v| v.to_array().as_ref()[r]))
}

impl Accel {
    /// Closest hits of `rays` (at most `F::WIDTH`, at most [`MAX_PACKET`])
    /// traversed as one packet, into `out[..rays.len()]`: bitwise
    /// [`Accel::intersect`] per ray (see the module notes).
    pub fn intersect_packet<F: Float>(
        &self,
        rays: &[Ray],
        shapes: &[Shape],
        instances: &[Instance],
        out: &mut [Option<Hit>],
    ) {
        let mut best = [None; MAX_PACKET];
        self.packet::<F, false>(rays, shapes, instances, &mut best);
        out[..rays.len()].copy_from_slice(&best[..rays.len()]);
    }

    /// Bit `r` set where `rays[r]` is blocked before its `t_max` (at most
    /// `F::WIDTH` rays, at most [`MAX_PACKET`]): [`Accel::occluded`] per ray.
    pub fn occluded_packet<F: Float>(&self, rays: &[Ray], shapes: &[Shape], instances: &[Instance]) -> u32 {
        let mut best = [None; MAX_PACKET];
        self.packet::<F, true>(rays, shapes, instances, &mut best)
    }

    /// Walks the tree with a packet; fills `best` (closest hits) and returns
    /// the mask of rays hit (for `ANY`, the rays blocked).
    #[inline(always)]
    fn packet<F: Float, const ANY: bool>(
        &self,
        rays: &[Ray],
        shapes: &[Shape],
        instances: &[Instance],
        best: &mut [Option<Hit>; MAX_PACKET],
    ) -> u32 {
        assert!(rays.len() <= F::WIDTH && rays.len() <= MAX_PACKET);
        let Some((root_child, root_info)) = self.root else { return 0 };
        if rays.is_empty() {
            return 0;
        }
        let all = (1u32 << rays.len()) - 1;
        let lanes = Lanes::<F>::new(rays);
        let ray_tri = RayTri::<F>::new(&lanes);
        // Per ray, the search limit: its own t_max, then a few ulps past
        // its closest hit so far (`search_limit`).
        let mut t_max = F::Array::default();
        for (l, r) in rays.iter().enumerate() {
            t_max.as_mut()[l] = r.t_max;
        }
        let widen = F::splat(1.0 + 2.0 * 3.0 * f32::EPSILON);
        let zero = F::splat(0.0);
        // Rays still searching (for `ANY`: not yet blocked).
        let mut alive = all;
        let mut hit = 0u32;
        // Ray `r` hit `h`: for `ANY` it stops, else `h` is its closest so
        // far if it beats the best one.
        macro_rules! record {
            ($r:expr, $h:expr) => {{
                let (r, h): (usize, Hit) = ($r, $h);
                hit |= 1 << r;
                if ANY {
                    alive &= !(1 << r);
                } else if h.beats(&best[r]) {
                    t_max.as_mut()[r] = search_limit(h.t, rays[r].t_max);
                    best[r] = Some(h);
                }
            }};
        }
        let mut stack = Stack::<F>::new();
        let mut cur = Entry { child: root_child, info: root_info, mask: all, t0: zero, key: 0.0 };
        loop {
            if cur.info == 0 && (cur.mask & alive).count_ones() <= FEW_RAYS {
                // Few rays left in this subtree: walk each with the single-ray
                // kernel (its best hit counts as one found here).
                let mut m = cur.mask & alive;
                while m != 0 {
                    let r = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let ray = Ray { t_max: t_max.as_ref()[r], ..rays[r] };
                    let (shear, inv_d) = (lane_shear(&ray_tri, r), lane_inv_d(&lanes, r));
                    if let Some(h) =
                        self.traverse_slot::<ANY>(&ray, &shear, inv_d, (cur.child, cur.info), shapes, instances)
                    {
                        record!(r, h);
                    }
                }
            } else if cur.info == 0 {
                let node = &self.nodes[cur.child as usize];
                let tm = F::from_array(t_max);
                let base = stack.len();
                let mut single: Option<Entry<F>> = None;
                let mut used = node.used as u32;
                while used != 0 {
                    let l = used.trailing_zeros() as usize;
                    used &= used - 1;
                    let slab = |row: usize, a: usize| {
                        let p = F::splat(dequantize(node.q[row][l], node.scale[a], node.origin[a]));
                        (p - lanes.o[a]) * lanes.inv_d[a]
                    };
                    let (lo, hi) = ([slab(0, 0), slab(2, 1), slab(4, 2)], [slab(1, 0), slab(3, 1), slab(5, 2)]);
                    let near: [F; 3] = std::array::from_fn(|a| F::select(lanes.neg[a], hi[a], lo[a]));
                    let far: [F; 3] = std::array::from_fn(|a| F::select(lanes.neg[a], lo[a], hi[a]));
                    let t0 = near[0].max(near[1]);
                    let t0 = t0.max(near[2].max(zero));
                    let t1 = far[0].min(far[1]);
                    let t1 = t1.min(far[2].min(tm));
                    let mask = t0.cmp_le(t1 * widen).bitmask() & cur.mask;
                    if mask == 0 {
                        continue;
                    }
                    let key = t0.to_array().as_ref()[mask.trailing_zeros() as usize];
                    let e = Entry { child: node.child[l], info: node.info[l] as u32, mask, t0, key };
                    if single.is_none() && stack.len() == base {
                        single = Some(e);
                        continue;
                    }
                    if let Some(s) = single.take() {
                        stack.push_sorted::<ANY>(base, s);
                    }
                    stack.push_sorted::<ANY>(base, e);
                }
                if let Some(s) = single {
                    cur = s;
                    continue;
                }
                if stack.len() > base {
                    cur = stack.pop().expect("entries were pushed");
                    continue;
                }
            } else if cur.info & OTHER == 0 {
                for blk in cur.child..cur.child + cur.info {
                    let tri = &self.tris[blk as usize];
                    if (cur.mask & alive).count_ones() >= LANE_TRIANGLES {
                        // Each triangle against all rays at once. The same
                        // rule as one ray against the block: every lane is
                        // tested with the block's starting t_max, and the
                        // nearest hit wins, the lowest lane among equals.
                        let tm = F::from_array(t_max);
                        let v = tri.v.map(|k| k.map(|c| c.to_array()));
                        #[allow(clippy::needless_range_loop)] // `k` indexes the ids too
                        for k in 0..4 {
                            if v[0][0][k].is_nan() {
                                break; // padding lanes come last
                            }
                            let tv = [0, 1, 2].map(|j| [v[j][0][k], v[j][1][k], v[j][2][k]]);
                            let (mask, t, b1, b2) = ray_tri.hit(&tv, tm);
                            let mut mask = mask & cur.mask & alive;
                            if mask == 0 {
                                continue;
                            }
                            hit |= mask;
                            if ANY {
                                alive &= !mask;
                                continue;
                            }
                            let (t, b1, b2) = (t.to_array(), b1.to_array(), b2.to_array());
                            let [shape, index] = self.tri_ids[blk as usize][k];
                            while mask != 0 {
                                let r = mask.trailing_zeros() as usize;
                                mask &= mask - 1;
                                let uv = Vec2::new(b1.as_ref()[r], b2.as_ref()[r]);
                                record!(r, Hit { t: t.as_ref()[r], uv, shape, index, instance: Hit::NOT_INSTANCED });
                            }
                        }
                        continue;
                    }
                    let mut m = cur.mask & alive;
                    while m != 0 {
                        let r = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let tr = t_max.as_ref()[r];
                        // Built here, not per packet: most blocks are reached by several rays.
                        let shear = RayShear::new(rays[r].d);
                        let single = Single { lanes: RayLanes::new(&rays[r], &shear), kz: shear.kz };
                        let (mut mask, t, b1, b2) = tri_hit(&single, tr, tri);
                        if mask == 0 {
                            continue;
                        }
                        hit |= 1 << r;
                        if ANY {
                            alive &= !(1 << r);
                            continue;
                        }
                        let (t, b1, b2) = (t.to_array(), b1.to_array(), b2.to_array());
                        while mask != 0 {
                            let k = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let [shape, index] = self.tri_ids[blk as usize][k];
                            let uv = Vec2::new(b1[k], b2[k]);
                            record!(r, Hit { t: t[k], uv, shape, index, instance: Hit::NOT_INSTANCED });
                        }
                    }
                }
            } else {
                let first = cur.child as usize;
                for prim in &self.prims[first..first + (cur.info & !OTHER) as usize] {
                    if let Primitive::Shape(shape) = *prim {
                        // A sphere or a disk against all rays at once.
                        let lanes_hit = if (cur.mask & alive).count_ones() >= LANE_TRIANGLES {
                            match &shapes[shape as usize] {
                                Shape::Sphere(s) => {
                                    let (mask, t) = sphere_hit(&lanes, s, F::from_array(t_max));
                                    Some((mask, t, zero, zero))
                                }
                                Shape::Disk(d) => Some(disk_hit(&lanes, d, F::from_array(t_max))),
                                _ => None,
                            }
                        } else {
                            None
                        };
                        if let Some((mask, t, u, v)) = lanes_hit {
                            let mut mask = mask & cur.mask & alive;
                            hit |= mask;
                            if ANY {
                                alive &= !mask;
                                continue;
                            }
                            let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                            while mask != 0 {
                                let r = mask.trailing_zeros() as usize;
                                mask &= mask - 1;
                                let uv = Vec2::new(u.as_ref()[r], v.as_ref()[r]);
                                record!(r, Hit { t: t.as_ref()[r], uv, shape, index: 0, instance: Hit::NOT_INSTANCED });
                            }
                            continue;
                        }
                    }
                    let mut m = cur.mask & alive;
                    while m != 0 {
                        let r = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let ray = Ray { t_max: t_max.as_ref()[r], ..rays[r] };
                        let found = prim_hit::<ANY>(*prim, &ray, shapes, instances);
                        if let Some(h) = found {
                            record!(r, h);
                        }
                    }
                }
            }
            if ANY && alive == 0 {
                return hit;
            }
            // Pop the next subtree some ray still enters before its closest hit.
            loop {
                let Some(mut e) = stack.pop() else { return hit };
                e.mask &= alive;
                if !ANY {
                    e.mask &= e.t0.cmp_le(F::from_array(t_max)).bitmask();
                }
                if e.mask != 0 {
                    cur = e;
                    break;
                }
            }
        }
    }
}

/// The traversal stack, left uninitialised: entries are written before
/// they are read (a heap allocation per packet would cost as much as
/// traversing it in small scenes).
struct Stack<F> {
    entries: [MaybeUninit<Entry<F>>; STACK],
    len: usize,
}

impl<F: Copy> Stack<F> {
    #[inline(always)]
    fn new() -> Self {
        Stack { entries: [const { MaybeUninit::uninit() }; STACK], len: 0 }
    }

    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry<F>> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries[..len] were written by `push_sorted`.
        Some(unsafe { self.entries[self.len].assume_init() })
    }

    /// Pushes `e` among the entries `base..`, kept sorted far to near (the
    /// nearest on top); any-hit traversal keeps them unsorted, as the
    /// single-ray kernel does. A full stack drops `e`, as there.
    #[inline(always)]
    fn push_sorted<const ANY: bool>(&mut self, base: usize, e: Entry<F>) {
        if self.len == STACK {
            debug_assert!(false, "BVH packet traversal stack overflow");
            return;
        }
        let mut k = self.len;
        // SAFETY: entries[base..len] were written before.
        while !ANY && k > base && unsafe { self.entries[k - 1].assume_init_ref() }.key < e.key {
            self.entries[k] = self.entries[k - 1];
            k -= 1;
        }
        self.entries[k].write(e);
        self.len += 1;
    }
}

/// Whether two closest hits are the same hit, bit for bit (t, uv, shape,
/// index, instance): what the packet and single-ray kernels must give.
pub fn same_hit(a: Option<Hit>, b: Option<Hit>) -> bool {
    let key = |h: Hit| (h.t.to_bits(), h.shape, h.index, h.instance, h.uv.x.to_bits(), h.uv.y.to_bits());
    a.map(key) == b.map(key)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::curves::Basis;
    use crate::geometry::ellipsoids::quat_to_matrix;
    use crate::geometry::{Curves, Ellipsoid, Ellipsoids, Mesh, SdfGrid, Shell, TriangleMesh};
    use crate::sampling::rng::{hash_words, to_unit_f32};
    use glam::Vec3;

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 77, k]))
    }

    /// A triangle soup, a grid of quads (shared edges and vertices, hit
    /// exactly by axis-aligned rays through them), spheres, and the
    /// multi-part shapes: a cloud of ellipsoids, culled ellipsoid shells,
    /// curves and a signed distance grid.
    fn scene() -> Vec<Shape> {
        let mut m = TriangleMesh::default();
        for i in 0..3000u64 {
            let c = Vec3::new(rnd(i, 0), rnd(i, 1), rnd(i, 2)) * 10.0;
            for k in 0..3 {
                m.positions.push(c + Vec3::new(rnd(i, 3 + 3 * k), rnd(i, 4 + 3 * k), rnd(i, 5 + 3 * k)) - 0.5);
            }
            let b = 3 * i as u32;
            m.indices.push([b, b + 1, b + 2]);
        }
        let mut g = TriangleMesh::default();
        let n = 10u32;
        for y in 0..=n {
            for x in 0..=n {
                g.positions.push(Vec3::new(x as f32, y as f32, -2.0));
            }
        }
        for y in 0..n {
            for x in 0..n {
                let v = y * (n + 1) + x;
                g.indices.push([v, v + 1, v + n + 2]);
                g.indices.push([v, v + n + 2, v + n + 1]);
            }
        }
        let ellipsoid = |i: u64| {
            let q = glam::DQuat::from_xyzw(
                rnd(i, 40) as f64 - 0.5,
                rnd(i, 41) as f64 - 0.5,
                rnd(i, 42) as f64 - 0.5,
                rnd(i, 43) as f64 - 0.5,
            )
            .normalize();
            Ellipsoid {
                center: Vec3::new(rnd(i, 44), rnd(i, 45), rnd(i, 46)) * 10.0,
                scale: Vec3::new(0.1 + rnd(i, 47), 0.1 + rnd(i, 48), 0.1 + rnd(i, 49)) * 0.6,
                rot: quat_to_matrix([q.x, q.y, q.z, q.w]).as_mat3(),
            }
        };
        // Radius 2 in the plane z = 0.5 (coplanar, so they tie).
        let disk = |c: Vec3| {
            Shape::disk(glam::Mat4::from_scale_rotation_translation(Vec3::splat(2.0), glam::Quat::IDENTITY, c), false)
        };
        let half = TriangleMesh { indices: g.indices[..n as usize * n as usize].to_vec(), ..g.clone() };
        let cloud: Vec<Ellipsoid> = (0..60).map(ellipsoid).collect();
        let shells: Vec<Ellipsoid> = (60..100).map(ellipsoid).collect();
        vec![
            Shape::Mesh(Mesh::new(m, false)),
            Shape::Mesh(Mesh::new(g, false)),
            Shape::sphere(Vec3::splat(5.0), 1.0, false),
            Shape::sphere(Vec3::new(2.0, 7.0, 3.0), 0.7, false),
            Shape::Ellipsoids(Ellipsoids { items: cloud }),
            Shape::CulledMesh(Mesh::new(Shell::IcoSphere.mesh(&shells), true)),
            helix(Basis::Linear, 0.0),
            helix(Basis::BSpline, 2.5),
            Shape::SdfGrid(sdf_blob(glam::DMat4::from_scale_rotation_translation(
                glam::DVec3::splat(3.0),
                glam::DQuat::IDENTITY,
                glam::DVec3::new(6.0, 1.0, 5.0),
            ))),
            // Exact ties between shapes: the grid again, half of it (the same
            // vertices, so the same t bits), a sphere twice, and two
            // overlapping coplanar disks.
            Shape::Mesh(Mesh::new(half, false)),
            Shape::sphere(Vec3::new(8.0, 2.0, 1.0), 0.8, false),
            Shape::sphere(Vec3::new(8.0, 2.0, 1.0), 0.8, false),
            disk(Vec3::new(3.0, 3.0, 0.5)),
            disk(Vec3::new(4.0, 3.5, 0.5)),
            // A disk turned and stretched, every matrix entry in its test.
            Shape::disk(
                glam::Mat4::from_scale_rotation_translation(
                    Vec3::new(2.5, 1.5, 1.0),
                    glam::Quat::from_euler(glam::EulerRot::XYZ, 0.7, -0.4, 1.1),
                    Vec3::new(5.0, 4.0, 6.0),
                ),
                true,
            ),
        ]
    }

    /// The closest hit found without a tree: every primitive tested, the
    /// least under [`Hit::beats`] kept, and how many hits tie with it.
    fn brute_force(shapes: &[Shape], ray: &Ray) -> (Option<Hit>, usize) {
        let mut best: Option<Hit> = None;
        let mut all = Vec::new();
        let shear = RayShear::new(ray.d);
        for (sid, shape) in shapes.iter().enumerate() {
            for i in 0..shape.prim_count() {
                let found = match shape {
                    Shape::Mesh(m) => crate::geometry::triangle::intersect_triangle(ray, &shear, &m.vertices(i))
                        .map(|(t, b1, b2)| (t, Vec2::new(b1, b2))),
                    _ => shape.intersect_prim(i, ray),
                };
                if let Some((t, uv)) = found {
                    let index = if shape.is_multi_part() || matches!(shape, Shape::Mesh(_)) { i as u32 } else { 0 };
                    let h = Hit { t, uv, shape: sid as u32, index, instance: Hit::NOT_INSTANCED };
                    all.push(t);
                    if h.beats(&best) {
                        best = Some(h);
                    }
                }
            }
        }
        let ties = best.map_or(0, |b| all.iter().filter(|&&t| t == b.t).count());
        (best, ties)
    }

    /// Curves along a helix (every tenth segment left out), lifted by `lift`.
    fn helix(basis: Basis, lift: f32) -> Shape {
        let points = (0..40)
            .map(|k| {
                let a = k as f32 * 0.5;
                glam::Vec4::new(
                    3.0 + 2.0 * a.cos(),
                    lift + 0.2 * k as f32,
                    6.0 + 2.0 * a.sin(),
                    0.05 + 0.1 * rnd(k, 50),
                )
            })
            .collect();
        let last = if basis == Basis::Linear { 39 } else { 37 };
        Shape::Curves(Curves { points, segments: (0..last).filter(|k| k % 10 != 9).collect(), basis })
    }

    /// A 9³ signed distance grid of two overlapping spheres, placed by `to_world`.
    pub(crate) fn sdf_blob(to_world: glam::DMat4) -> SdfGrid {
        let n = 9;
        let mut data = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = glam::DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                    let a = (p - glam::DVec3::new(0.4, 0.5, 0.5)).length() - 0.3;
                    let b = (p - glam::DVec3::new(0.7, 0.6, 0.4)).length() - 0.2;
                    data.push(a.min(b) as f32);
                }
            }
        }
        SdfGrid::new([n; 3], data, to_world, true).unwrap()
    }

    /// Coherent bundles (a pinhole's rays over a small patch, some aimed
    /// exactly at the grid's shared vertices), incoherent rays, and short
    /// shadow-like segments.
    fn rays() -> Vec<Ray> {
        let mut v = Vec::new();
        for i in 0..6000u64 {
            let kind = (i / 16) % 4;
            let b = i / 16;
            let o = match kind {
                0 | 1 => Vec3::new(5.0, 5.0, 20.0) + Vec3::new(rnd(b, 10), rnd(b, 11), 0.0),
                _ => Vec3::new(rnd(i, 10), rnd(i, 11), rnd(i, 12)) * 12.0 - 1.0,
            };
            let (d, t_max) = match kind {
                0 => (
                    (Vec3::new(rnd(b, 13) * 10.0, rnd(b, 14) * 10.0, 0.0) - o
                        + Vec3::new(rnd(i, 15), rnd(i, 16), 0.0) * 0.5)
                        .normalize(),
                    f32::INFINITY,
                ),
                // Straight down through the grid's vertices.
                1 => (Vec3::NEG_Z, f32::INFINITY),
                2 => ((Vec3::new(rnd(i, 13), rnd(i, 14), rnd(i, 15)) - 0.5).normalize(), f32::INFINITY),
                _ => ((Vec3::new(rnd(i, 13), rnd(i, 14), rnd(i, 15)) - 0.5).normalize(), 3.0 * rnd(i, 16)),
            };
            let o = if kind == 1 { Vec3::new((i % 11) as f32, ((i / 11) % 11) as f32, 1.0 + rnd(i, 17)) } else { o };
            v.push(Ray::new(o, d, t_max));
        }
        v
    }

    fn check<F: Float>() {
        single_rays_are_the_kernels::<F>();
        let shapes = scene();
        let accel = Accel::build_shapes(&shapes);
        let rays = rays();
        let (mut hits, mut ties, mut parts) = (0, 0, 0);
        // The single-ray kernel against every primitive tested alone.
        for (i, ray) in rays.iter().enumerate() {
            let (expect, tied) = brute_force(&shapes, ray);
            let single = accel.intersect(ray, &shapes, &[]);
            assert!(same_hit(single, expect), "ray {i}: {single:?} vs every primitive's {expect:?}");
            ties += (tied > 1) as usize;
        }
        for n in [F::WIDTH, 3.min(F::WIDTH)] {
            for (c, chunk) in rays.chunks(n).enumerate() {
                let mut out = [None; MAX_PACKET];
                accel.intersect_packet::<F>(chunk, &shapes, &[], &mut out);
                let blocked = accel.occluded_packet::<F>(chunk, &shapes, &[]);
                for (r, ray) in chunk.iter().enumerate() {
                    let single = accel.intersect(ray, &shapes, &[]);
                    assert!(same_hit(out[r], single), "{} chunk {c} ray {r}: {:?} vs {:?}", F::NAME, out[r], single);
                    hits += single.is_some() as usize;
                    parts += single.is_some_and(|h| shapes[h.shape as usize].is_multi_part()) as usize;
                    assert_eq!(
                        blocked & (1 << r) != 0,
                        accel.occluded(ray, &shapes, &[]),
                        "{} chunk {c} ray {r}",
                        F::NAME
                    );
                }
                assert_eq!(blocked >> chunk.len(), 0);
            }
        }
        assert!(hits > 3000, "{hits}");
        assert!(parts > 300, "{parts} hits on ellipsoids and shells");
        // Shared edges and vertices, the duplicated grid, sphere and disks.
        assert!(ties > 500, "{ties} rays whose closest hit ties");
        eprintln!("{}: {hits} hits ({parts} on multi-part shapes), {ties} ties", F::NAME);
    }

    /// The shear and reciprocal direction a packet hands the single-ray
    /// kernel are bitwise the ones that kernel computes itself, on rays
    /// with ties between |d| components too.
    fn single_rays_are_the_kernels<F: Float>() {
        let mut rays = rays();
        rays.extend(
            [Vec3::ONE, Vec3::new(1.0, -1.0, 0.5), Vec3::new(0.5, 2.0, -2.0), Vec3::NEG_X, Vec3::Y]
                .map(|d| Ray::new(Vec3::ZERO, d, 1.0)),
        );
        let bits = |v: [f32; 3]| v.map(f32::to_bits);
        for chunk in rays.chunks(F::WIDTH) {
            let lanes = Lanes::<F>::new(chunk);
            let ray_tri = RayTri::new(&lanes);
            for (r, ray) in chunk.iter().enumerate() {
                let (got, want) = (lane_shear(&ray_tri, r), RayShear::new(ray.d));
                assert_eq!(got.kz, want.kz, "{} {ray:?}", F::NAME);
                assert_eq!(bits([got.sx, got.sy, got.sz]), bits([want.sx, want.sy, want.sz]), "{ray:?}");
                assert_eq!(bits(lane_inv_d(&lanes, r).to_array()), bits(ray.d.recip().to_array()), "{ray:?}");
            }
        }
    }

    #[test]
    fn packets_match_single_rays_scalar() {
        check::<f32>();
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    #[test]
    fn packets_match_single_rays_x8() {
        check::<crate::simd::F32x8>();
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    #[test]
    fn packets_match_single_rays_x16() {
        check::<crate::simd::F32x16>();
    }

    /// `disk_hit` against [`Disk::intersect`] alone, lane by lane and bit
    /// for bit (mask, t and uv), on every disk of the test scene: rays aimed
    /// at points inside, on and past its rim, some with a short `t_max`.
    fn disks_in_lanes<F: Float>() {
        let shapes = scene();
        let mut hits = 0;
        for (k, shape) in shapes.iter().enumerate() {
            let Shape::Disk(disk) = shape else { continue };
            let rays: Vec<Ray> = (0..2000u64)
                .map(|i| {
                    let i = i + 10_000 * k as u64;
                    let (r, phi) = (1.2 * rnd(i, 60).sqrt(), 2.0 * std::f32::consts::PI * rnd(i, 61));
                    let target = disk.world_from_object.transform_point3(Vec3::new(r * phi.cos(), r * phi.sin(), 0.0));
                    let o = Vec3::new(rnd(i, 62), rnd(i, 63), rnd(i, 64)) * 16.0 - 3.0;
                    let t_max = if i % 4 == 0 { 20.0 * rnd(i, 65) } else { f32::INFINITY };
                    Ray::new(o, (target - o).normalize(), t_max)
                })
                .collect();
            for chunk in rays.chunks(F::WIDTH) {
                let mut t_max = F::Array::default();
                for (l, r) in chunk.iter().enumerate() {
                    t_max.as_mut()[l] = r.t_max;
                }
                let (mask, t, u, v) = disk_hit(&Lanes::<F>::new(chunk), disk, F::from_array(t_max));
                let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                for (l, ray) in chunk.iter().enumerate() {
                    let expect = disk.intersect(ray);
                    assert_eq!(mask >> l & 1 != 0, expect.is_some(), "{} disk {k} lane {l}", F::NAME);
                    if let Some((te, uv)) = expect {
                        let got = [t.as_ref()[l], u.as_ref()[l], v.as_ref()[l]].map(f32::to_bits);
                        assert_eq!(got, [te, uv.x, uv.y].map(f32::to_bits), "{} disk {k} lane {l}", F::NAME);
                        hits += 1;
                    }
                }
            }
        }
        // Three disks, about (1/1.2)² of the aimed rays inside each.
        assert!(hits > 3000, "{hits} disk hits");
    }

    #[test]
    fn disks_in_lanes_are_bitwise_the_single_ray_test() {
        disks_in_lanes::<f32>();
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
        disks_in_lanes::<crate::simd::F32x8>();
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        disks_in_lanes::<crate::simd::F32x16>();
    }

    #[test]
    fn empty_tree_and_empty_packet() {
        let accel = Accel::build_shapes(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        let mut out = [Some(Hit { t: 1.0, uv: Vec2::ZERO, shape: 0, index: 0, instance: 0 })];
        accel.intersect_packet::<f32>(&[ray], &[], &[], &mut out);
        assert!(out[0].is_none());
        assert_eq!(accel.occluded_packet::<f32>(&[ray], &[], &[]), 0);
        let shapes = scene();
        let accel = Accel::build_shapes(&shapes);
        assert_eq!(accel.occluded_packet::<f32>(&[], &shapes, &[]), 0);
    }
}
