//! Light selection by importance: a BVH over the lights' spatial and
//! directional bounds, descended stochastically towards the lights likely to
//! matter at a receiver, as pbrt-v4's `BVHLightSampler` (Pharr et al., 4th
//! ed., §12.6.3).
//!
//! Lights at infinity (constant, envmap, directional) stay outside the tree
//! and share a fixed probability, n_inf / (n_inf + 1) when the tree is not
//! empty. Finite lights with zero power are never picked. Each tree light
//! remembers its leaf's bit trail (bit d: which child was taken at depth d) so
//! that [`LightBvh::pmf`] repeats the descent of [`LightBvh::sample`] with the
//! same floating-point operations in the same order: the two agree exactly.
//!
//! Deviations from pbrt-v4: bounds are kept in f32 (no `CompactLightBounds`
//! quantisation); an emissive mesh is one light here (pbrt makes one per
//! triangle), bounded by a normal cone over all its faces; the SAH considers
//! every bucket boundary and falls back to a median split instead of pbrt's
//! unordered middle split; a spot light's φ is 4π I as in pbrt rather than its
//! cone's flux, so that it compares with point lights of the same intensity.

use super::Light;
use crate::geometry::{Aabb, Shape};
use crate::math::{safe_acos, safe_asin, safe_sqrt, PI};
use glam::{Quat, Vec3};

/// Largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
/// Importance is capped so that the sum of two stays finite.
const MAX_IMPORTANCE: f32 = f32::MAX / 4.0;
/// Buckets of the binned SAH (pbrt's 12).
const BUCKETS: usize = 12;
/// Below this depth splits use the SAH; deeper ones split at the median, so
/// leaves stay within 32 + log2(n) ≤ 64 levels and a bit trail fits a u64.
const SAH_MAX_DEPTH: u32 = 32;

/// Angle between unit vectors, accurate for nearly (anti)parallel ones (pbrt-v4 §3.3.2).
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * safe_asin((a + b).length() / 2.0)
    } else {
        2.0 * safe_asin((b - a).length() / 2.0)
    }
}

/// A cone of directions: unit axis `w` and the cosine of its half-angle (pbrt-v4 §3.8.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DirectionCone {
    pub(crate) w: Vec3,
    pub(crate) cos_theta: f32,
}

impl DirectionCone {
    pub(crate) const ENTIRE_SPHERE: DirectionCone = DirectionCone { w: Vec3::Z, cos_theta: -1.0 };

    /// The cone bounding both `a` and `b` (pbrt-v4 §3.8.4, `Union`).
    fn union(a: DirectionCone, b: DirectionCone) -> DirectionCone {
        let (theta_a, theta_b) = (safe_acos(a.cos_theta), safe_acos(b.cos_theta));
        let theta_d = angle_between(a.w, b.w);
        if (theta_d + theta_b).min(PI) <= theta_a {
            return a;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return b;
        }
        let theta_o = (theta_a + theta_d + theta_b) / 2.0;
        if theta_o >= PI {
            return DirectionCone::ENTIRE_SPHERE;
        }
        // Rotate a's axis towards b's by θ_o - θ_a.
        let wr = a.w.cross(b.w);
        if wr.length_squared() == 0.0 {
            return DirectionCone::ENTIRE_SPHERE;
        }
        let w = Quat::from_axis_angle(wr.normalize(), theta_o - theta_a) * a.w;
        DirectionCone { w: w.normalize(), cos_theta: theta_o.cos() }
    }
}

/// Spatial bounds of one light's emission: a box, a direction cone (axis,
/// cos θ_o, cos θ_e), power (luminance of flux), two_sided flag.
///
/// Emission leaves points of `bounds` only in directions within θ_o + θ_e of
/// `w` (of ±`w` when `two_sided`): θ_o bounds the emitters' normals (or
/// beam axes), θ_e the spread of emission around each (pbrt-v4 §12.6.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    /// Box of the emitting points, in world space.
    pub bounds: Aabb,
    /// Unit axis of the direction cone.
    pub w: Vec3,
    /// Power: the luminance of the emitted flux (4π I for point and spot lights).
    pub phi: f32,
    /// cos θ_o: the half-angle around `w` that bounds the normals (or beam axes).
    pub cos_theta_o: f32,
    /// cos θ_e: the spread of emission around each normal (0 for diffuse emitters, θ_e = π/2).
    pub cos_theta_e: f32,
    /// Emission around ±`w` rather than `w` alone.
    pub two_sided: bool,
}

impl LightBounds {
    /// Bounds of one-sided emission from points of `bounds` in directions
    /// within acos(`cos_theta_e`) of the directions of `cone`, with power `phi`.
    pub(crate) fn new(bounds: Aabb, cone: DirectionCone, cos_theta_e: f32, phi: f32) -> LightBounds {
        LightBounds { bounds, w: cone.w, phi, cos_theta_o: cone.cos_theta, cos_theta_e, two_sided: false }
    }

    /// Whether the bounds hold a light the tree can pick: positive, finite
    /// power and a nonempty box.
    pub fn emits(&self) -> bool {
        self.phi > 0.0 && self.phi.is_finite() && !self.bounds.is_empty()
    }

    /// pbrt's importance of these bounds for a receiver at p with normal n
    /// (n = Vec3::ZERO when unknown, e.g. on media).
    ///
    /// φ cos θ' / d², times cos θ'_i at surfaces, where θ' (θ'_i) is the
    /// smallest angle the bounds allow between the emission cone (the
    /// receiver's normal) and the direction between light and receiver
    /// (pbrt-v4 §12.6.1, `LightBounds::Importance`). Zero only where no
    /// bounded emitter can reach `p` (and for a point-like light exactly in
    /// `p`'s tangent plane). As in pbrt, d² is clamped below by half the box's
    /// diagonal and the receiver is two-sided (|cos θ_i|). `n` must be unit
    /// length or zero. Finite, at most `f32::MAX / 4`.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        PreparedBounds::new(self).importance(p, n)
    }

    #[inline]
    fn centroid(&self) -> Vec3 {
        self.bounds.center()
    }

    /// Bounds of two sets of lights together (pbrt-v4 §12.6.1, `Union`).
    fn union(&self, o: &LightBounds) -> LightBounds {
        let cone = DirectionCone::union(
            DirectionCone { w: self.w, cos_theta: self.cos_theta_o },
            DirectionCone { w: o.w, cos_theta: o.cos_theta_o },
        );
        LightBounds {
            bounds: self.bounds.union(o.bounds),
            w: cone.w,
            phi: self.phi + o.phi,
            cos_theta_o: cone.cos_theta,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// pbrt-v4's split cost (§12.6.3, `EvaluateCost`): φ times the direction
    /// measure M_Ω of the cone times the box's surface area, stretched by
    /// K_r = max extent / extent along the split axis to discourage thin boxes.
    fn cost(&self, node_extent: Vec3, dim: usize) -> f32 {
        let theta_o = safe_acos(self.cos_theta_o);
        let theta_e = safe_acos(self.cos_theta_e);
        let theta_w = (theta_o + theta_e).min(PI);
        let sin_theta_o = safe_sqrt(1.0 - self.cos_theta_o * self.cos_theta_o);
        let m_omega = 2.0 * PI * (1.0 - self.cos_theta_o)
            + PI / 2.0
                * (2.0 * theta_w * sin_theta_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_theta_o
                    + self.cos_theta_o);
        let k_r = node_extent.max_element() / node_extent[dim];
        self.phi * m_omega * k_r * self.bounds.area()
    }
}

/// [`LightBounds`] with what the importance needs precomputed, as tree nodes store them.
#[derive(Debug, Clone, Copy)]
struct PreparedBounds {
    center: Vec3,
    /// Radius of the box's bounding sphere.
    radius: f32,
    /// pbrt's floor on the squared distance: half the box's diagonal.
    min_d2: f32,
    w: Vec3,
    phi: f32,
    cos_theta_o: f32,
    sin_theta_o: f32,
    cos_theta_e: f32,
    two_sided: bool,
}

impl PreparedBounds {
    fn new(b: &LightBounds) -> PreparedBounds {
        let center = b.bounds.center();
        PreparedBounds {
            center,
            radius: if b.bounds.is_empty() { 0.0 } else { center.distance(b.bounds.max) },
            min_d2: b.bounds.extent().length() / 2.0,
            w: b.w,
            phi: b.phi,
            cos_theta_o: b.cos_theta_o,
            sin_theta_o: safe_sqrt(1.0 - b.cos_theta_o * b.cos_theta_o),
            cos_theta_e: b.cos_theta_e,
            two_sided: b.two_sided,
        }
    }

    /// See [`LightBounds::importance`].
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let dist2 = p.distance_squared(self.center);
        let d2 = dist2.max(self.min_d2).max(f32::MIN_POSITIVE);
        // Directions subtended by the box's bounding sphere (pbrt's
        // `BoundSubtendedDirections`): all of them when p is inside.
        if dist2 <= self.radius * self.radius {
            // θ_b = π: every cosine bound is 1.
            if 1.0 <= self.cos_theta_e {
                return 0.0;
            }
            return (self.phi / d2).min(MAX_IMPORTANCE);
        }
        let inv_dist = 1.0 / dist2.sqrt();
        let sin_theta_b = (self.radius * inv_dist).min(1.0);
        let cos_theta_b = safe_sqrt(1.0 - sin_theta_b * sin_theta_b);

        // cos and sin of max(0, θ_a - θ_b).
        let cos_sub_clamped = |sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32| -> f32 {
            if cos_a > cos_b {
                1.0
            } else {
                cos_a * cos_b + sin_a * sin_b
            }
        };
        let sin_sub_clamped = |sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32| -> f32 {
            if cos_a > cos_b {
                0.0
            } else {
                sin_a * cos_b - cos_a * sin_b
            }
        };

        // θ_w: angle between the cone axis and the direction towards p.
        let wi = (p - self.center) * inv_dist;
        let mut cos_theta_w = self.w.dot(wi);
        if self.two_sided {
            cos_theta_w = cos_theta_w.abs();
        }
        let sin_theta_w = safe_sqrt(1.0 - cos_theta_w * cos_theta_w);

        // θ' = max(0, θ_w - θ_o - θ_b), tested against θ_e.
        let cos_theta_x = cos_sub_clamped(sin_theta_w, cos_theta_w, self.sin_theta_o, self.cos_theta_o);
        let sin_theta_x = sin_sub_clamped(sin_theta_w, cos_theta_w, self.sin_theta_o, self.cos_theta_o);
        let cos_theta_p = cos_sub_clamped(sin_theta_x, cos_theta_x, sin_theta_b, cos_theta_b);
        if cos_theta_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_theta_p / d2;

        // cos θ'_i = cos max(0, θ_i - θ_b) at surfaces.
        if n != Vec3::ZERO {
            let cos_theta_i = wi.dot(n).abs();
            let sin_theta_i = safe_sqrt(1.0 - cos_theta_i * cos_theta_i);
            importance *= cos_sub_clamped(sin_theta_i, cos_theta_i, sin_theta_b, cos_theta_b);
        }
        importance.clamp(0.0, MAX_IMPORTANCE)
    }
}

#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: PreparedBounds,
    /// Leaf: the light's index; interior: the second child (the first follows the node).
    child_or_light: u32,
    is_leaf: bool,
}

/// Where light `i` lives.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    /// Never picked (zero power).
    None,
    Infinite,
    /// In the tree, reached by this bit trail.
    Tree(u64),
}

/// pbrt-v4's `BVHLightSampler` (§12.6.3).
#[derive(Debug, Clone)]
pub struct LightBvh {
    nodes: Vec<Node>,
    infinite: Vec<u32>,
    slots: Vec<Slot>,
    /// Probability of each infinite light: 1 / (n_inf + 1 if the tree is not empty).
    pmf_infinite: f32,
    /// n_inf · pmf_infinite as pbrt computes it: n_inf / (n_inf + 1).
    p_infinite: f32,
    /// Probability of descending the tree: 1 - p_infinite.
    p_tree: f32,
}

impl LightBvh {
    /// Builds over all lights of the scene. Lights at infinity (those
    /// without [`Light::bounds`]: constant, envmap, and directional ones too)
    /// are kept outside the tree and sampled with a fixed probability as pbrt
    /// does: p_inf = n_inf / (n_inf + 1), or 1 when the tree is empty. Finite
    /// lights of zero power get probability 0.
    pub fn build(lights: &[Light], shapes: &[Shape]) -> LightBvh {
        let mut bvh = LightBvh {
            nodes: Vec::new(),
            infinite: Vec::new(),
            slots: vec![Slot::None; lights.len()],
            pmf_infinite: 0.0,
            p_infinite: 0.0,
            p_tree: 0.0,
        };
        let mut items = Vec::new();
        for (i, light) in lights.iter().enumerate() {
            match light.bounds(shapes) {
                None => {
                    bvh.slots[i] = Slot::Infinite;
                    bvh.infinite.push(i as u32);
                }
                Some(b) if b.emits() => items.push((i as u32, b)),
                Some(_) => {}
            }
        }
        if !items.is_empty() {
            bvh.nodes.reserve(2 * items.len() - 1);
            bvh.build_node(&mut items, 0, 0);
        }
        let n_inf = bvh.infinite.len() as f32;
        let denom = n_inf + if bvh.nodes.is_empty() { 0.0 } else { 1.0 };
        if denom > 0.0 {
            bvh.p_infinite = n_inf / denom;
            bvh.pmf_infinite = 1.0 / denom;
            bvh.p_tree = 1.0 - bvh.p_infinite;
        }
        bvh
    }

    /// Recursive build (pbrt-v4 §12.6.3, `buildBVH`); returns the bounds of `items`.
    fn build_node(&mut self, items: &mut [(u32, LightBounds)], trail: u64, depth: u32) -> LightBounds {
        if let [(light, bounds)] = items {
            self.slots[*light as usize] = Slot::Tree(trail);
            self.nodes.push(Node { bounds: PreparedBounds::new(bounds), child_or_light: *light, is_leaf: true });
            return *bounds;
        }
        let mid = if depth < SAH_MAX_DEPTH { sah_split(items) } else { None };
        let mid = mid.unwrap_or_else(|| median_split(items));
        let index = self.nodes.len();
        self.nodes.push(Node { bounds: PreparedBounds::new(&items[0].1), child_or_light: 0, is_leaf: false });
        let (left, right) = items.split_at_mut(mid);
        let b0 = self.build_node(left, trail, depth + 1);
        let second = self.nodes.len() as u32;
        let b1 = self.build_node(right, trail | (1u64 << depth), depth + 1);
        let bounds = b0.union(&b1);
        self.nodes[index] = Node { bounds: PreparedBounds::new(&bounds), child_or_light: second, is_leaf: false };
        bounds
    }

    /// Picks a light for a receiver at (p, n): (light index, probability).
    /// None if nothing can be picked: no light, or the descent reached a
    /// node whose two children both have zero importance (pbrt does the same;
    /// the sample then carries no light, and [`LightBvh::pmf`] accounts for it).
    ///
    /// `n`: unit (shading) normal, or zero for receivers without one; `u` in
    /// [0, 1). Cost: two importance evaluations per tree level.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32)> {
        self.sample_remapped(p, n, u).map(|(i, pmf, _)| (i, pmf))
    }

    /// [`LightBvh::sample`], also returning `u` remapped to [0, 1) within the
    /// choice made, for reuse (as `Distribution1D::sample_discrete`).
    pub fn sample_remapped(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        let mut u = u.clamp(0.0, ONE_MINUS_EPSILON);
        if u < self.p_infinite {
            let k = self.infinite.len();
            let scaled = u / self.p_infinite * k as f32;
            let i = (scaled as usize).min(k - 1);
            let u_re = (scaled - i as f32).clamp(0.0, ONE_MINUS_EPSILON);
            return Some((self.infinite[i] as usize, self.pmf_infinite, u_re));
        }
        if self.nodes.is_empty() {
            return None;
        }
        u = ((u - self.p_infinite) / self.p_tree).min(ONE_MINUS_EPSILON);
        let (light, pmf) = self.descend(p, n, |p0| {
            // Go to the second child with probability 1 - p0, remapping u.
            let right = u >= p0;
            u = if right {
                ((u - p0) / (1.0 - p0)).clamp(0.0, ONE_MINUS_EPSILON)
            } else {
                (u / p0).min(ONE_MINUS_EPSILON)
            };
            right
        })?;
        Some((light, pmf, u))
    }

    /// Probability that `sample(p, n, ·)` returns `light`: bit-identical to
    /// the probability `sample` returns with it, since both walk the tree
    /// through `LightBvh::descend`; 0 for lights never picked there (and
    /// for indices out of range).
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f32 {
        let mut trail = match self.slots.get(light) {
            None | Some(Slot::None) => return 0.0,
            Some(Slot::Infinite) => return self.pmf_infinite,
            Some(Slot::Tree(trail)) => *trail,
        };
        let steer = |_p0: f32| {
            let right = trail & 1 == 1;
            trail >>= 1;
            right
        };
        self.descend(p, n, steer).map_or(0.0, |(_, pmf)| pmf)
    }

    /// Walks from the root to a leaf, choosing at each interior node between
    /// children in proportion to their importance; `go_right(p0)` decides,
    /// given the first child's probability p0. Returns the leaf's light and
    /// the product of the choices' probabilities (times the tree's share),
    /// or None where the receiver sees zero importance.
    #[inline]
    fn descend(&self, p: Vec3, n: Vec3, mut go_right: impl FnMut(f32) -> bool) -> Option<(usize, f32)> {
        let mut pmf = self.p_tree;
        let mut index = 0;
        loop {
            let node = &self.nodes[index];
            if node.is_leaf {
                // Below the root a leaf was only reached through its positive importance.
                let reachable = index > 0 || node.bounds.importance(p, n) > 0.0;
                return (reachable && pmf > 0.0).then_some((node.child_or_light as usize, pmf));
            }
            let second = node.child_or_light as usize;
            let c0 = self.nodes[index + 1].bounds.importance(p, n);
            let c1 = self.nodes[second].bounds.importance(p, n);
            if c0 == 0.0 && c1 == 0.0 {
                return None;
            }
            let p0 = c0 / (c0 + c1);
            if go_right(p0) {
                pmf *= c1 / (c0 + c1);
                index = second;
            } else {
                pmf *= p0;
                index += 1;
            }
        }
    }

    /// Number of lights in the tree.
    pub fn tree_len(&self) -> usize {
        self.nodes.len().div_ceil(2)
    }

    /// Depth of the deepest leaf (0 for a tree of one light or none).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[Node], i: usize) -> usize {
            let node = &nodes[i];
            if node.is_leaf {
                0
            } else {
                1 + walk(nodes, i + 1).max(walk(nodes, node.child_or_light as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0)
        }
    }
}

/// Binned SAH split with pbrt's cost; returns the size of the first part, or
/// None when no split separates the lights at a positive cost.
fn sah_split(items: &mut [(u32, LightBounds)]) -> Option<usize> {
    let node = items.iter().fold(Aabb::EMPTY, |b, (_, lb)| b.union(lb.bounds));
    let centroids = items.iter().fold(Aabb::EMPTY, |b, (_, lb)| b.grow(lb.centroid()));
    let node_extent = node.extent();
    let bucket_of = |c: Vec3, dim: usize| -> usize {
        let t = (c[dim] - centroids.min[dim]) / (centroids.max[dim] - centroids.min[dim]);
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for dim in 0..3 {
        if centroids.max[dim] <= centroids.min[dim] {
            continue;
        }
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, lb) in items.iter() {
            let b = &mut buckets[bucket_of(lb.centroid(), dim)];
            *b = Some(b.map_or(*lb, |x| x.union(lb)));
        }
        // Prefix and suffix unions: below[i] holds buckets 0..=i, above[i] buckets i+1...
        let join = |acc: Option<LightBounds>, b: &Option<LightBounds>| match (acc, b) {
            (Some(a), Some(b)) => Some(a.union(b)),
            (a, b) => a.or(*b),
        };
        let mut below = [None; BUCKETS];
        let mut acc = None;
        for i in 0..BUCKETS {
            acc = join(acc, &buckets[i]);
            below[i] = acc;
        }
        let mut above = [None; BUCKETS];
        let mut acc = None;
        for i in (1..BUCKETS).rev() {
            acc = join(acc, &buckets[i]);
            above[i - 1] = acc;
        }
        for i in 0..BUCKETS - 1 {
            if let (Some(b0), Some(b1)) = (below[i], above[i]) {
                let cost = b0.cost(node_extent, dim) + b1.cost(node_extent, dim);
                if cost > 0.0 && cost.is_finite() && !best.is_some_and(|(c, _, _)| c <= cost) {
                    best = Some((cost, dim, i));
                }
            }
        }
    }
    let (_, dim, split) = best?;
    // Partition in place: lights in buckets 0..=split first.
    let mut mid = 0;
    for j in 0..items.len() {
        if bucket_of(items[j].1.centroid(), dim) <= split {
            items.swap(mid, j);
            mid += 1;
        }
    }
    (mid > 0 && mid < items.len()).then_some(mid)
}

/// Splits at the median centroid along the widest centroid axis.
fn median_split(items: &mut [(u32, LightBounds)]) -> usize {
    let mid = items.len() / 2;
    let centroids = items.iter().fold(Aabb::EMPTY, |b, (_, lb)| b.grow(lb.centroid()));
    let e = centroids.extent();
    let dim = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    if e[dim] > 0.0 {
        items.select_nth_unstable_by(mid, |a, b| a.1.centroid()[dim].total_cmp(&b.1.centroid()[dim]));
    }
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, TriangleMesh};
    use crate::light::{AreaLight, ConstantLight, DirectionalLight, PointLight, SpotLight};
    use crate::math::{look_at, luminance, Mat4, Spectrum};
    use crate::sampling::rng::{hash_words, to_unit_f32};
    use crate::testing::chi2::alpha;
    use glam::Vec2;
    use statrs::distribution::{ChiSquared, ContinuousCDF};

    fn rnd(seed: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[seed, k]))
    }

    fn rnd_vec(seed: u64, k: u64) -> Vec3 {
        Vec3::new(rnd(seed, 3 * k), rnd(seed, 3 * k + 1), rnd(seed, 3 * k + 2))
    }

    fn rnd_dir(seed: u64, k: u64) -> Vec3 {
        let u = Vec2::new(rnd(seed ^ 0x5555, 2 * k), rnd(seed ^ 0x5555, 2 * k + 1));
        crate::sampling::warp::sample_uniform_sphere(u)
    }

    fn mesh_shape(mut m: TriangleMesh, world_from_object: Mat4) -> Shape {
        m.transform(&world_from_object);
        Shape::Mesh(Mesh::new(m, false))
    }

    /// A rectangle of half-sizes `half` centred at `c`, facing `n`.
    fn rectangle(c: Vec3, n: Vec3, half: Vec2) -> Shape {
        let m = Mat4::from_translation(c)
            * Mat4::from_quat(Quat::from_rotation_arc(Vec3::Z, n.normalize()))
            * Mat4::from_scale(half.extend(1.0));
        mesh_shape(TriangleMesh::rectangle(), m)
    }

    fn area(shapes: &mut Vec<Shape>, shape: Shape, radiance: f32) -> Light {
        shapes.push(shape);
        Light::Area(AreaLight {
            shape: shapes.len() as u32 - 1,
            radiance: Spectrum::splat(radiance).into(),
            two_sided: false,
        })
    }

    fn spot(pos: Vec3, target: Vec3, intensity: f32, cutoff_deg: f32) -> Light {
        let up = if (target - pos).normalize().y.abs() > 0.9 { Vec3::X } else { Vec3::Y };
        Light::Spot(SpotLight::new(look_at(pos, target, up), Spectrum::splat(intensity), cutoff_deg, 0.75 * cutoff_deg))
    }

    /// 50 lights in [-10, 10]³: rectangles, disks, spheres, cubes, points, spots and one constant light.
    fn mixed_scene(seed: u64) -> (Vec<Light>, Vec<Shape>) {
        let (mut lights, mut shapes) = (Vec::new(), Vec::new());
        let pos = |k: u64| rnd_vec(seed, k) * 20.0 - Vec3::splat(10.0);
        let mut k = 0u64;
        let mut next = || {
            k += 1;
            k
        };
        for _ in 0..12 {
            let (c, n, s) = (pos(next()), rnd_dir(seed, next()), 0.2 + rnd(seed, next()));
            lights.push(area(&mut shapes, rectangle(c, n, Vec2::new(s, 0.5 * s)), 1.0 + 5.0 * rnd(seed, next())));
        }
        for _ in 0..6 {
            let (c, n, r) = (pos(next()), rnd_dir(seed, next()), 0.1 + 0.5 * rnd(seed, next()));
            let m = Mat4::from_translation(c)
                * Mat4::from_quat(Quat::from_rotation_arc(Vec3::Z, n))
                * Mat4::from_scale(Vec3::splat(r));
            lights.push(area(&mut shapes, Shape::disk(m, rnd(seed, next()) < 0.5), 2.0));
        }
        for _ in 0..8 {
            let (c, r) = (pos(next()), 0.1 + 0.6 * rnd(seed, next()));
            lights.push(area(&mut shapes, Shape::sphere(c, r, false), 0.5 + 3.0 * rnd(seed, next())));
        }
        for _ in 0..4 {
            let m = Mat4::from_translation(pos(next())) * Mat4::from_scale(Vec3::splat(0.3));
            lights.push(area(&mut shapes, mesh_shape(TriangleMesh::cube(), m), 1.5));
        }
        for _ in 0..10 {
            let (c, i) = (pos(next()), 1.0 + 20.0 * rnd(seed, next()));
            lights.push(Light::Point(PointLight { position: c, intensity: Spectrum::splat(i) }));
        }
        for _ in 0..9 {
            let (c, t, i, a) =
                (pos(next()), pos(next()), 5.0 + 50.0 * rnd(seed, next()), 10.0 + 50.0 * rnd(seed, next()));
            lights.push(spot(c, t, i, a));
        }
        lights.push(Light::Constant(ConstantLight { radiance: Spectrum::splat(0.2) }));
        assert_eq!(lights.len(), 50);
        (lights, shapes)
    }

    /// Random receivers in [-12, 12]³, half with a random normal, half without.
    fn receivers(seed: u64, count: u64) -> Vec<(Vec3, Vec3)> {
        (0..count)
            .map(|k| {
                let p = rnd_vec(seed ^ 0xabc, k) * 24.0 - Vec3::splat(12.0);
                let n = if k % 2 == 0 { rnd_dir(seed ^ 0xdef, k) } else { Vec3::ZERO };
                (p, n)
            })
            .collect()
    }

    /// Chi-square p-value of observed counts against expected ones (pooling cells below 5).
    fn chi2_p_value(observed: &[f64], expected: &[f64]) -> f64 {
        let mut order: Vec<usize> = (0..observed.len()).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
        let (mut chi2, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
        for &c in &order {
            if expected[c] <= 0.0 {
                assert_eq!(observed[c], 0.0, "cell {c} was sampled but has probability 0");
                continue;
            }
            if expected[c] < 5.0 {
                pool_o += observed[c];
                pool_e += expected[c];
                if pool_e < 5.0 {
                    continue;
                }
                chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                (pool_o, pool_e) = (0.0, 0.0);
            } else {
                chi2 += (observed[c] - expected[c]).powi(2) / expected[c];
            }
            dof += 1;
        }
        if pool_e > 0.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            dof += 1;
        }
        1.0 - ChiSquared::new((dof.max(2) - 1) as f64).unwrap().cdf(chi2)
    }

    /// Checks sampling against the pmf at one receiver: the probability
    /// `sample` returns is bit-identical to `pmf`; with stratified u each
    /// light owns an interval of u of length pmf (counts within ±2); with
    /// random u the frequencies pass a chi-square test (with "none" as one
    /// more cell). Returns (Σ pmf, fraction of u for which sample gave none).
    fn check_receiver(bvh: &LightBvh, n_lights: usize, seed: u64, p: Vec3, n: Vec3, alpha: f64) -> (f64, f64) {
        let pmf: Vec<f32> = (0..n_lights).map(|i| bvh.pmf(p, n, i)).collect();
        let sum: f64 = pmf.iter().map(|&x| x as f64).sum();
        assert!(sum <= 1.0 + 1e-4, "receiver {p}: Σ pmf = {sum}");

        let m = 200_000usize;
        let mut counts = vec![0f64; n_lights + 1];
        for k in 0..m {
            let u = (k as f32 + 0.5) / m as f32;
            match bvh.sample(p, n, u) {
                Some((i, prob)) => {
                    assert_eq!(prob.to_bits(), pmf[i].to_bits(), "receiver {p}: sample and pmf disagree for {i}");
                    counts[i] += 1.0;
                }
                None => counts[n_lights] += 1.0,
            }
        }
        let missed = counts[n_lights] / m as f64;
        assert!((sum + missed - 1.0).abs() < 1e-4, "receiver {p}: Σ pmf = {sum}, P(none) = {missed}");
        for (i, &c) in counts[..n_lights].iter().enumerate() {
            let expect = pmf[i] as f64 * m as f64;
            assert!((c - expect).abs() <= 2.0 + 1e-5 * m as f64, "receiver {p}, light {i}: {c} vs {expect}");
        }

        let m = 100_000usize;
        let mut observed = vec![0f64; n_lights + 1];
        for k in 0..m as u64 {
            match bvh.sample(p, n, to_unit_f32(hash_words(&[seed, k]))) {
                Some((i, _)) => observed[i] += 1.0,
                None => observed[n_lights] += 1.0,
            }
        }
        let mut expected: Vec<f64> = pmf.iter().map(|&x| x as f64 * m as f64).collect();
        expected.push(missed * m as f64);
        let pv = chi2_p_value(&observed, &expected);
        assert!(pv > alpha, "receiver {p}: chi-square p = {pv}");
        (sum, missed)
    }

    #[test]
    fn pmf_sums_to_one_and_matches_sampling_frequencies() {
        // Lights that emit in every direction: no descent dead-ends, Σ pmf = 1.
        let (mut lights, mut shapes) = (Vec::new(), Vec::new());
        for k in 0..40u64 {
            let c = rnd_vec(21, k) * 20.0 - Vec3::splat(10.0);
            lights.push(match k % 4 {
                0 => Light::Point(PointLight { position: c, intensity: Spectrum::splat(1.0 + 9.0 * rnd(22, k)) }),
                1 => area(&mut shapes, Shape::sphere(c, 0.1 + rnd(22, k), false), 2.0),
                2 => area(&mut shapes, Shape::sphere(c, 0.3, true), 1.0),
                _ => {
                    let m = Mat4::from_translation(c) * Mat4::from_scale(Vec3::splat(0.1 + rnd(22, k)));
                    area(&mut shapes, mesh_shape(TriangleMesh::cube(), m), 3.0)
                }
            });
        }
        lights.push(Light::Constant(ConstantLight { radiance: Spectrum::splat(0.2) }));
        lights.push(Light::Directional(DirectionalLight {
            direction: -Vec3::Y,
            irradiance: Spectrum::ONE,
            scene_radius: 20.0,
        }));
        let bvh = LightBvh::build(&lights, &shapes);
        assert_eq!(bvh.tree_len(), 40);
        let recv = receivers(13, 16);
        for (r, &(p, n)) in recv.iter().enumerate() {
            let (sum, missed) = check_receiver(&bvh, lights.len(), 100 + r as u64, p, n, alpha(2 * recv.len()));
            assert!((sum - 1.0).abs() < 1e-4 && missed == 0.0, "receiver {r}: Σ pmf = {sum}, P(none) = {missed}");
            assert_eq!(bvh.pmf(p, n, 40), 1.0 / 3.0);
        }

        // Mixed lights: one-sided and spot lights can make the descent end
        // where both children are unimportant (as pbrt's); then Σ pmf =
        // 1 - P(none) and the remaining probability yields no light.
        let (lights, shapes) = mixed_scene(7);
        let bvh = LightBvh::build(&lights, &shapes);
        assert_eq!(bvh.tree_len(), 49);
        assert!(bvh.depth() <= 20, "depth {}", bvh.depth());
        let mut full = 0;
        for (r, &(p, n)) in recv.iter().enumerate() {
            let (sum, missed) = check_receiver(&bvh, lights.len(), 200 + r as u64, p, n, alpha(2 * recv.len()));
            if missed == 0.0 {
                full += 1;
                assert!((sum - 1.0).abs() < 1e-4, "receiver {r}: Σ pmf = {sum}");
            }
            assert!(missed < 0.25, "receiver {r}: P(none) = {missed}");
            // The constant light keeps its fixed share.
            assert_eq!(bvh.pmf(p, n, 49), 0.5);
        }
        assert!(full > 0);
    }

    #[test]
    fn lights_that_reach_a_receiver_have_positive_pmf() {
        let (lights, shapes) = mixed_scene(3);
        let bvh = LightBvh::build(&lights, &shapes);
        let mut reached = 0;
        for &(p, n) in &receivers(5, 64) {
            for (i, light) in lights.iter().enumerate() {
                let reaches = (0..64).any(|k| {
                    let u = Vec2::new((k % 8) as f32 / 8.0 + 0.0625, (k / 8) as f32 / 8.0 + 0.0625);
                    light
                        .sample_li(p, u, &shapes)
                        .is_some_and(|s| luminance(s.li) > 0.0 && (n == Vec3::ZERO || s.wi.dot(n) != 0.0))
                });
                if reaches {
                    reached += 1;
                    assert!(bvh.pmf(p, n, i) > 0.0, "light {i} reaches {p} (n = {n}) but has pmf 0");
                }
            }
        }
        assert!(reached > 1000);
    }

    #[test]
    fn one_sided_lights_are_unimportant_from_behind() {
        let shapes = vec![rectangle(Vec3::ZERO, Vec3::Z, Vec2::splat(0.5))];
        let light = Light::Area(AreaLight { shape: 0, radiance: Spectrum::ONE.into(), two_sided: false });
        let b = light.bounds(&shapes).unwrap();
        assert!((b.w - Vec3::Z).length() < 1e-5 && b.cos_theta_o > 0.99999 && !b.two_sided);
        let (front, back) = (Vec3::new(0.3, 0.2, 3.0), Vec3::new(0.3, 0.2, -3.0));
        assert!(b.importance(front, Vec3::ZERO) > 0.0);
        assert!(b.importance(front, Vec3::Z) > 0.0);
        assert_eq!(b.importance(back, Vec3::ZERO), 0.0);
        assert_eq!(b.importance(back, -Vec3::Z), 0.0);
        // Beside it, in its plane: the box still subtends directions in front.
        assert!(b.importance(Vec3::new(3.0, 0.0, 0.0), Vec3::ZERO) > 0.0);
        // Receivers are two-sided, as in pbrt.
        assert_eq!(b.importance(Vec3::new(0.0, 0.0, 5.0), Vec3::X), b.importance(Vec3::new(0.0, 0.0, 5.0), -Vec3::X));

        let bvh = LightBvh::build(std::slice::from_ref(&light), &shapes);
        assert_eq!(bvh.pmf(front, Vec3::ZERO, 0), 1.0);
        assert_eq!(bvh.sample(front, Vec3::ZERO, 0.7), Some((0, 1.0)));
        assert_eq!(bvh.pmf(back, Vec3::ZERO, 0), 0.0);
        assert_eq!(bvh.sample(back, Vec3::ZERO, 0.7), None);

        // A spot light seen from outside its beam.
        let s = spot(Vec3::ZERO, Vec3::Z, 1.0, 20.0).bounds(&[]).unwrap();
        assert!((s.w - Vec3::Z).length() < 1e-5);
        assert!((s.cos_theta_e - 20f32.to_radians().cos()).abs() < 1e-5, "{}", s.cos_theta_e);
        assert!(s.importance(Vec3::new(0.0, 0.5, 3.0), Vec3::ZERO) > 0.0);
        assert_eq!(s.importance(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO), 0.0);
        assert_eq!(s.importance(Vec3::new(0.0, 0.0, -3.0), Vec3::ZERO), 0.0);
    }

    #[test]
    fn nearer_lights_are_more_likely() {
        let mut shapes = Vec::new();
        let near = area(&mut shapes, rectangle(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, Vec2::splat(0.5)), 1.0);
        let far = area(&mut shapes, rectangle(Vec3::new(1.0, 0.0, 20.0), -Vec3::Z, Vec2::splat(0.5)), 1.0);
        let points = [Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, -30.0, 0.0)]
            .map(|c| Light::Point(PointLight { position: c, intensity: Spectrum::ONE }));
        let lights = vec![near, far, points[0].clone(), points[1].clone()];
        let bvh = LightBvh::build(&lights, &shapes);
        for n in [Vec3::ZERO, Vec3::new(0.0, 0.6, 0.8)] {
            let pmf: Vec<f32> = (0..4).map(|i| bvh.pmf(Vec3::ZERO, n, i)).collect();
            assert!(pmf[0] > 10.0 * pmf[1] && pmf[1] > 0.0, "{pmf:?}");
            assert!(pmf[2] > 10.0 * pmf[3] && pmf[3] > 0.0, "{pmf:?}");
            assert!((pmf.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn degenerate_light_sets() {
        // No light at all.
        let bvh = LightBvh::build(&[], &[]);
        assert_eq!(bvh.sample(Vec3::ZERO, Vec3::Z, 0.3), None);
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::Z, 0), 0.0);
        // One point light.
        let point = Light::Point(PointLight { position: Vec3::X, intensity: Spectrum::ONE });
        let bvh = LightBvh::build(std::slice::from_ref(&point), &[]);
        assert_eq!((bvh.tree_len(), bvh.depth()), (1, 0));
        for u in [0.0, 0.5, ONE_MINUS_EPSILON] {
            assert_eq!(bvh.sample(Vec3::ZERO, Vec3::ZERO, u), Some((0, 1.0)));
        }
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::new(0.6, 0.8, 0.0), 0), 1.0);
        // In the receiver's tangent plane: nothing to gain.
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::Y, 0), 0.0);
        // At the light's own position: still finite.
        assert_eq!(bvh.pmf(Vec3::X, Vec3::ZERO, 0), 1.0);
        // Only lights at infinity: uniform among them.
        let constant = Light::Constant(ConstantLight { radiance: Spectrum::ONE.into() });
        let sun =
            Light::Directional(DirectionalLight { direction: -Vec3::Y, irradiance: Spectrum::ONE, scene_radius: 1.0 });
        let bvh = LightBvh::build(&[constant.clone(), sun.clone()], &[]);
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::ZERO, 0), 0.5);
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::ZERO, 1), 0.5);
        assert_eq!(bvh.sample(Vec3::ZERO, Vec3::ZERO, 0.2), Some((0, 0.5)));
        assert_eq!(bvh.sample_remapped(Vec3::ZERO, Vec3::ZERO, 0.75), Some((1, 0.5, 0.5)));
        // Infinite plus finite: the tree counts as one more.
        let dark = Light::Point(PointLight { position: Vec3::Y, intensity: Spectrum::ZERO });
        let lights = [constant, dark, sun, point];
        let bvh = LightBvh::build(&lights, &[]);
        let pmf: Vec<f32> = (0..4).map(|i| bvh.pmf(Vec3::ZERO, Vec3::ZERO, i)).collect();
        assert_eq!(pmf, [1.0 / 3.0, 0.0, 1.0 / 3.0, 1.0 - 2.0 / 3.0]);
        for k in 0..1000 {
            let (i, prob) = bvh.sample(Vec3::ZERO, Vec3::ZERO, k as f32 / 1000.0).unwrap();
            assert_eq!(prob, pmf[i]);
            assert_ne!(i, 1, "a light without power was picked");
        }
        assert_eq!(bvh.pmf(Vec3::ZERO, Vec3::ZERO, 17), 0.0);
    }

    #[test]
    fn many_coincident_and_collinear_lights_build_shallow_trees() {
        for (name, f) in [
            ("coincident", (|_k: usize| Vec3::ONE) as fn(usize) -> Vec3),
            ("collinear", |k| Vec3::new(k as f32, 0.0, 0.0)),
            ("geometric", |k| Vec3::new(1.1f32.powi(k as i32 % 400), 0.0, 0.0)),
        ] {
            let lights: Vec<Light> =
                (0..3000).map(|k| Light::Point(PointLight { position: f(k), intensity: Spectrum::ONE })).collect();
            let bvh = LightBvh::build(&lights, &[]);
            assert!(bvh.depth() <= 64, "{name}: depth {}", bvh.depth());
            let p = Vec3::new(5.0, 1.0, 0.0);
            let sum: f64 = (0..lights.len()).map(|i| bvh.pmf(p, Vec3::ZERO, i) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-4, "{name}: Σ pmf = {sum}");
        }
    }

    #[test]
    fn cone_unions_contain_both_cones() {
        for k in 0..2000 {
            let cone = |j: u64| DirectionCone {
                w: rnd_dir(k, j),
                cos_theta: if rnd(k, 10 + j) < 0.2 { 1.0 } else { rnd(k, 20 + j) * 2.0 - 1.0 },
            };
            let (a, b) = (cone(0), cone(1));
            let u = DirectionCone::union(a, b);
            assert!((u.w.length() - 1.0).abs() < 1e-5);
            let (theta_u, theta_a, theta_b) = (safe_acos(u.cos_theta), safe_acos(a.cos_theta), safe_acos(b.cos_theta));
            for (c, theta) in [(a, theta_a), (b, theta_b)] {
                assert!(
                    angle_between(u.w, c.w) + theta <= theta_u + 1e-4 || u.cos_theta == -1.0,
                    "{a:?} ∪ {b:?} = {u:?}"
                );
            }
        }
    }

    #[test]
    fn spot_bounds_follow_its_transform() {
        let s = spot(Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, -5.0, 3.0), 2.0, 35.0);
        let b = s.bounds(&[]).unwrap();
        assert!((b.w + Vec3::Y).length() < 1e-5 && b.cos_theta_o == 1.0);
        assert!((b.cos_theta_e - 35f32.to_radians().cos()).abs() < 1e-5);
        assert!((b.phi - 8.0 * PI).abs() < 1e-4);
        // A non-uniformly scaled spot loses its direction bound, not its light.
        let Light::Spot(mut sl) = s else { unreachable!() };
        sl.light_from_world = Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0)) * sl.light_from_world;
        let b = Light::Spot(sl).bounds(&[]).unwrap();
        assert_eq!((b.cos_theta_o, b.cos_theta_e), (-1.0, 0.0));
    }
}
