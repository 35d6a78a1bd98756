//! The directional quadtree of path guiding (Müller, Gross and Novák,
//! "Practical Path Guiding for Efficient Light-Transport Simulation", EGSR
//! 2017, sec. 3.2): a piecewise-constant density over the sphere of
//! directions, refined where the incident radiance is large.
//!
//! Directions live on the unit square by the cylindrical map
//! (u, v) = ((cos θ + 1) / 2, φ / 2π), which preserves area: a density p on
//! the square is p / 4π per steradian. A node splits its square into four
//! quadrants, numbered `ix + 2 iy`.
//!
//! Two forms: [`DTreeBuilder`] gathers one iteration's radiance records
//! (sums in f64, in the order records come, so the result does not depend
//! on threads), and [`DTree`] is its frozen, normalised copy that sampling
//! and [`DTree::pdf`] read.

use crate::math::PI;
use crate::simd::{Float, V3};
use glam::{Vec2, Vec3};

/// Deepest level a quadtree refines to (the paper's 20).
pub const MAX_DEPTH: u32 = 20;

/// A quadtree node: per quadrant, the index of its child node (0: the
/// quadrant is a leaf; node 0 is the root, nobody's child).
#[derive(Debug, Clone, Copy, Default)]
struct Node {
    child: [u32; 4],
}

/// Square position of a direction (the cylindrical map).
#[inline]
pub fn dir_to_square(d: Vec3) -> Vec2 {
    let z = d.z.clamp(-1.0, 1.0);
    let mut phi = atan2(d.y, d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let v = phi * (0.5 / PI);
    // atan2 of a tiny negative y rounds phi + 2π to 2π exactly.
    Vec2::new(((z + 1.0) * 0.5).min(ONE_BELOW), if v >= 1.0 { 0.0 } else { v })
}

/// atan2(y, x) in [−π, π], within 3e-7 of the exact angle (about an f32 ulp
/// at π, as libm's `atan2f`): Cephes' `atanf` polynomial on [0, tan π/8]
/// after folding the octant, inlined where libm's is a call (a guided vertex
/// maps directions several times; libm's atan took 12 % of a guided render).
#[inline]
fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if den == 0.0 {
        return 0.0;
    }
    let t = num / den;
    let (base, z) = if t > 0.414_213_57 { (FRAC_PI_4, (t - 1.0) / (t + 1.0)) } else { (0.0, t) };
    let z2 = z * z;
    let p = ((8.053_744_5e-2 * z2 - 1.387_768_6e-1) * z2 + 1.997_771_1e-1) * z2 - 3.333_295e-1;
    let mut a = base + (p * z2 * z + z);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 {
        -a
    } else {
        a
    }
}

/// [`dir_to_square`] of every lane: its operations per lane, its branches
/// as selects, so each lane is bitwise the scalar map (NaN included). A
/// guided lane vertex maps up to four directions; one at a time, the map
/// and its division were half of the guide's density lookups.
#[inline]
pub fn dir_to_square_lanes<F: Float>(d: V3<F>) -> (F, F) {
    let (one, zero) = (F::splat(1.0), F::splat(0.0));
    // f32::clamp: NaN stays NaN.
    let z = F::select(d.z.cmp_lt(-one), -one, d.z);
    let z = F::select(z.cmp_gt(one), one, z);
    let phi = atan2_lanes(d.y, d.x);
    let phi = F::select(phi.cmp_lt(zero), phi + F::splat(2.0 * PI), phi);
    let v = phi * F::splat(0.5 / PI);
    // `min` as f32::min against a number: the number where z is NaN.
    (((z + one) * F::splat(0.5)).min(F::splat(ONE_BELOW)), F::select(v.cmp_ge(one), zero, v))
}

/// [`atan2`] of every lane, bitwise the scalar one per lane.
#[inline]
fn atan2_lanes<F: Float>(y: F, x: F) -> F {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
    let (one, zero) = (F::splat(1.0), F::splat(0.0));
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay.cmp_gt(ax);
    let (num, den) = (F::select(swap, ax, ay), F::select(swap, ay, ax));
    let t = num / den;
    let big = t.cmp_gt(F::splat(0.414_213_57));
    let base = F::select(big, F::splat(FRAC_PI_4), zero);
    let z = F::select(big, (t - one) / (t + one), t);
    let z2 = z * z;
    let p = ((F::splat(8.053_744_5e-2) * z2 - F::splat(1.387_768_6e-1)) * z2 + F::splat(1.997_771_1e-1)) * z2
        - F::splat(3.333_295e-1);
    let a = base + (p * z2 * z + z);
    let a = F::select(swap, F::splat(FRAC_PI_2) - a, a);
    let a = F::select(x.cmp_lt(zero), F::splat(PI) - a, a);
    let a = F::select(y.cmp_lt(zero), -a, a);
    F::select(den.cmp_eq(zero), zero, a)
}

/// The direction at a square position (inverse of [`dir_to_square`]).
#[inline]
pub fn square_to_dir(p: Vec2) -> Vec3 {
    let z = 2.0 * p.x - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * p.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// The quadrant of a node's square holding `p`, and `p` in that quadrant's
/// own unit square: the one descent step `record` and `pdf_square` share.
#[inline]
fn quadrant(p: Vec2) -> (usize, Vec2) {
    let (ix, iy) = (p.x >= 0.5, p.y >= 0.5);
    let q = ix as usize + 2 * iy as usize;
    (q, Vec2::new(if ix { p.x * 2.0 - 1.0 } else { p.x * 2.0 }, if iy { p.y * 2.0 - 1.0 } else { p.y * 2.0 }))
}

/// One iteration's radiance records on a fixed structure.
#[derive(Debug, Clone)]
pub struct DTreeBuilder {
    nodes: Vec<Node>,
    /// Per node, the radiance recorded in each quadrant (Σ L / p).
    sums: Vec<[f64; 4]>,
}

impl Default for DTreeBuilder {
    /// The root alone: four leaf quadrants.
    fn default() -> Self {
        DTreeBuilder { nodes: vec![Node::default()], sums: vec![[0.0; 4]] }
    }
}

impl DTreeBuilder {
    /// Adds `value` (a radiance estimate over its sampling density) to the
    /// leaf quadrant holding square position `p` and to every quadrant above it.
    pub fn record(&mut self, p: Vec2, value: f64) {
        let (mut p, mut node) = (p, 0usize);
        loop {
            let q;
            (q, p) = quadrant(p);
            self.sums[node][q] += value;
            match self.nodes[node].child[q] {
                0 => return,
                c => node = c as usize,
            }
        }
    }

    /// The radiance recorded in all.
    pub fn total(&self) -> f64 {
        self.sums[0].iter().sum()
    }

    /// The sampling tree of these records: each quadrant's probability its
    /// share of its node's sum (a quarter each where a node got nothing).
    pub fn freeze(&self) -> DTree {
        let prob = self
            .sums
            .iter()
            .map(|s| {
                let t: f64 = s.iter().sum();
                if t > 0.0 && t.is_finite() {
                    s.map(|x| (x / t) as f32)
                } else {
                    [0.25; 4]
                }
            })
            .collect();
        DTree::new(self.nodes.clone(), prob, 0.0)
    }

    /// [`Self::freeze`], knowing that `records` records were added: the
    /// tree also estimates incident radiance ([`DTree::radiance`]).
    pub fn freeze_counted(&self, records: u64) -> DTree {
        let flux = if records > 0 { (self.total() / records as f64) as f32 } else { 0.0 };
        let mut tree = self.freeze();
        tree.flux = if flux.is_finite() { flux } else { 0.0 };
        tree
    }

    /// An empty builder whose structure refines this one's by its records
    /// (the paper's reset): a quadrant holding more than `threshold` of the
    /// total is subdivided (down to [`MAX_DEPTH`]), one holding less is a
    /// leaf. Where the old tree has no children, its quadrant's sum is
    /// taken as spread evenly over the four new ones.
    pub fn refined(&self, threshold: f64) -> DTreeBuilder {
        let total = self.total();
        let mut out = DTreeBuilder::default();
        // (new node, its old node or None with the old quadrant's sum, depth)
        let mut stack: Vec<(usize, Option<usize>, f64, u32)> = vec![(0, Some(0), total, 1)];
        while let Some((new, old, sum, depth)) = stack.pop() {
            for q in 0..4 {
                let (s, old_child) = match old {
                    Some(o) => (self.sums[o][q], self.nodes[o].child[q]),
                    None => (sum / 4.0, 0),
                };
                let fraction = if total > 0.0 { s / total } else { 0.25f64.powi(depth as i32) };
                if depth < MAX_DEPTH && fraction > threshold {
                    let c = out.nodes.len();
                    out.nodes.push(Node::default());
                    out.sums.push([0.0; 4]);
                    out.nodes[new].child[q] = c as u32;
                    stack.push((c, (old_child != 0).then_some(old_child as usize), s, depth + 1));
                }
            }
        }
        out
    }

    /// Nodes in the tree (for memory reports).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

/// Little-endian reading of a checkpoint's guide: each read checks the
/// bytes are there, so damaged input is an error, never a panic.
pub(crate) struct Bytes<'a> {
    pub b: &'a [u8],
    pub at: usize,
}

impl Bytes<'_> {
    pub fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len()).ok_or("the guide is truncated")?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    pub fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_bits(self.u32()?))
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// A count of items of `size` bytes each that the remaining bytes can hold.
    pub fn count(&mut self, size: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        if n.saturating_mul(size) > self.b.len() - self.at {
            return Err(format!("the guide claims {n} items, more than its bytes hold"));
        }
        Ok(n)
    }
}

/// Writes quadtree nodes; reads them back checking that every child comes
/// after its parent and within the tree (so descents end).
fn put_nodes(out: &mut Vec<u8>, nodes: &[Node]) {
    out.extend_from_slice(&(nodes.len() as u32).to_le_bytes());
    for n in nodes {
        for c in n.child {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
}

fn get_nodes(r: &mut Bytes) -> Result<Vec<Node>, String> {
    let n = r.count(16)?;
    if n == 0 {
        return Err("a quadtree without a root".into());
    }
    let mut nodes = Vec::with_capacity(n);
    for i in 0..n {
        let mut node = Node::default();
        for c in &mut node.child {
            *c = r.u32()?;
            if *c != 0 && (*c as usize <= i || *c as usize >= n) {
                return Err(format!("quadtree node {i} has child {c} (of {n})"));
            }
        }
        nodes.push(node);
    }
    Ok(nodes)
}

impl DTreeBuilder {
    /// Appends the builder to a checkpoint's bytes.
    pub fn encode(&self, out: &mut Vec<u8>) {
        put_nodes(out, &self.nodes);
        for s in self.sums.iter().flatten() {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }

    pub(crate) fn decode(r: &mut Bytes) -> Result<DTreeBuilder, String> {
        let nodes = get_nodes(r)?;
        let mut sums = Vec::with_capacity(nodes.len());
        for _ in 0..nodes.len() {
            let mut s = [0.0; 4];
            for v in &mut s {
                *v = r.f64()?;
                if !(v.is_finite() && *v >= 0.0) {
                    return Err(format!("a quadtree sum of {v}"));
                }
            }
            sums.push(s);
        }
        Ok(DTreeBuilder { nodes, sums })
    }
}

/// Levels of a quadtree that [`DTree::pdf_square`] reads from one table
/// instead of walking them: a guided vertex looks the density up three or
/// four times, and the walk's dependent loads were a fifth of a guided render.
pub(crate) const TOP: u32 = 4;
/// Cells per side of that table.
pub(crate) const TOP_SIDE: usize = 1 << TOP;

/// A cell of the square at depth [`TOP`]: the density so far, and the node
/// whose quadrants go on below it (0: a leaf ends at or above it, and
/// `pdf` is its density).
#[derive(Debug, Clone, Copy, Default)]
struct TopCell {
    pdf: f32,
    node: u32,
}

/// A frozen quadtree: the density that guided directions are drawn from.
#[derive(Debug, Clone)]
pub struct DTree {
    nodes: Vec<Node>,
    /// Per node, each quadrant's probability given the node (they sum to 1).
    prob: Vec<[f32; 4]>,
    /// The mean of the records it was built from, Φ ≈ ∫ L_i dω over the
    /// sphere (0: unknown), so that L_i(ω) ≈ Φ · pdf(ω) (see [`Self::radiance`]).
    flux: f32,
    /// The first [`TOP`] levels as a table of `TOP_SIDE`² cells (row by
    /// row), their densities multiplied in the walk's order, so a lookup
    /// through it gives the walk's bits.
    top: Vec<TopCell>,
}

impl Default for DTree {
    /// The uniform density over the sphere.
    fn default() -> Self {
        DTreeBuilder::default().freeze()
    }
}

impl DTree {
    /// The tree of these nodes and probabilities, with its table of the top levels.
    fn new(nodes: Vec<Node>, prob: Vec<[f32; 4]>, flux: f32) -> DTree {
        let mut top = vec![TopCell::default(); TOP_SIDE * TOP_SIDE];
        // (node, its depth, its lower-left cell, the density above it)
        let mut stack = vec![(0usize, 0u32, 0usize, 0usize, 1.0f32)];
        while let Some((node, depth, x0, y0, pdf)) = stack.pop() {
            let half = TOP_SIDE >> (depth + 1);
            for (q, (&p, &child)) in prob[node].iter().zip(&nodes[node].child).enumerate() {
                let (x, y) = (x0 + (q & 1) * half, y0 + (q >> 1) * half);
                let mut d = pdf;
                d *= 4.0 * p;
                if depth + 1 == TOP || child == 0 {
                    for row in top[y * TOP_SIDE..(y + half) * TOP_SIDE].chunks_exact_mut(TOP_SIDE) {
                        row[x..x + half].fill(TopCell { pdf: d, node: child });
                    }
                } else {
                    stack.push((child as usize, depth + 1, x, y, d));
                }
            }
        }
        DTree { nodes, prob, flux, top }
    }

    /// A square position drawn from the density with `u` in [0, 1)², and
    /// its density on the square (the product over levels of 4 × the
    /// chosen quadrant's probability). Hierarchical sample warping: each
    /// level picks a column, then a row in it, and rescales `u` to reuse it.
    pub fn sample_square(&self, u: Vec2) -> (Vec2, f32) {
        let (mut u, mut node, mut pdf) = (u, 0usize, 1.0f32);
        let (mut origin, mut size) = (Vec2::ZERO, 1.0f32);
        loop {
            let p = &self.prob[node];
            // The column (ix), then the row (iy) within it.
            let (left, right) = (p[0] + p[2], p[1] + p[3]);
            let pl = left / (left + right);
            let ix = if u.x < pl {
                u.x /= pl;
                0
            } else {
                u.x = (u.x - pl) / (1.0 - pl);
                1
            };
            let (bottom, top) = (p[ix], p[ix + 2]);
            let pb = bottom / (bottom + top);
            let iy = if u.y < pb {
                u.y /= pb;
                0
            } else {
                u.y = (u.y - pb) / (1.0 - pb);
                1
            };
            u = u.min(Vec2::splat(ONE_BELOW));
            let q = ix + 2 * iy;
            pdf *= 4.0 * p[q];
            size *= 0.5;
            origin += Vec2::new(ix as f32, iy as f32) * size;
            match self.nodes[node].child[q] {
                0 => return ((origin + u * size).min(Vec2::splat(ONE_BELOW)), pdf),
                c => node = c as usize,
            }
        }
    }

    /// The density on the square at `p`: the walk from the root, its first
    /// 4 levels (`TOP`) read from the table. Scaling by 2^TOP and taking the
    /// fraction is exact, as each level's doubling is.
    pub fn pdf_square(&self, p: Vec2) -> f32 {
        let s = p * TOP_SIDE as f32;
        let (cx, cy) = ((s.x as usize).min(TOP_SIDE - 1), (s.y as usize).min(TOP_SIDE - 1));
        let cell = self.top[cy * TOP_SIDE + cx];
        if cell.node == 0 {
            return cell.pdf;
        }
        self.walk(cell.node as usize, s - Vec2::new(cx as f32, cy as f32), cell.pdf)
    }

    /// The density at `p`, walking down from `node` (`p` in the node's
    /// unit square) with `pdf` the density above it.
    #[inline]
    pub(crate) fn walk(&self, node: usize, p: Vec2, pdf: f32) -> f32 {
        let (mut p, mut node, mut pdf) = (p, node, pdf);
        loop {
            let q;
            (q, p) = quadrant(p);
            pdf *= 4.0 * self.prob[node][q];
            match self.nodes[node].child[q] {
                0 => return pdf,
                c => node = c as usize,
            }
        }
    }

    /// Its table of the top levels, cell by cell (row by row): the density
    /// so far and the node [`Self::walk`] goes on from (0: none).
    pub(crate) fn top_cells(&self) -> impl Iterator<Item = (f32, u32)> + '_ {
        self.top.iter().map(|c| (c.pdf, c.node))
    }

    /// A world direction drawn from the density, and its density per
    /// steradian.
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (p, pdf) = self.sample_square(u);
        (square_to_dir(p), pdf * (0.25 / PI))
    }

    /// The density per steradian of direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.pdf_square(dir_to_square(d)) * (0.25 / PI)
    }

    /// Φ, the mean record: the radiance arriving from all directions,
    /// ∫ L_i dω (0 where no record was counted).
    #[inline]
    pub fn flux(&self) -> f32 {
        self.flux
    }

    /// The radiance arriving from a direction drawn with density `pdf`
    /// from this tree, Φ · pdf: each record is L / p, so a cell's share of
    /// their sum, over its solid angle, estimates L_i there.
    #[inline]
    pub fn radiance(&self, pdf: f32) -> f32 {
        self.flux * pdf
    }

    /// Nodes in the tree (for memory reports).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes of the table of its top levels (for memory reports).
    pub fn table_bytes(&self) -> usize {
        self.top.len() * std::mem::size_of::<TopCell>()
    }

    /// Appends the tree to a checkpoint's bytes.
    pub fn encode(&self, out: &mut Vec<u8>) {
        put_nodes(out, &self.nodes);
        for p in self.prob.iter().flatten() {
            out.extend_from_slice(&p.to_le_bytes());
        }
        out.extend_from_slice(&self.flux.to_le_bytes());
    }

    pub(crate) fn decode(r: &mut Bytes) -> Result<DTree, String> {
        let nodes = get_nodes(r)?;
        let mut prob = Vec::with_capacity(nodes.len());
        for _ in 0..nodes.len() {
            let mut p = [0.0f32; 4];
            for v in &mut p {
                *v = r.f32()?;
            }
            // As `freeze` makes them: shares of a node, summing to 1.
            let sum: f32 = p.iter().sum();
            if !p.iter().all(|v| v.is_finite() && *v >= 0.0) || (sum - 1.0).abs() > 1e-3 {
                return Err(format!("quadtree probabilities {p:?}"));
            }
            prob.push(p);
        }
        let flux = r.f32()?;
        if !(flux.is_finite() && flux >= 0.0) {
            return Err(format!("a quadtree's mean record of {flux}"));
        }
        Ok(DTree::new(nodes, prob, flux))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{alpha, chi2_test, integrate_over_sphere};
    use crate::testing::TestRng;

    /// Radiance from a bright cap around `axis` over a dim uniform floor.
    fn lobe(axis: Vec3, d: Vec3) -> f64 {
        0.05 + if d.dot(axis) > 0.9 { 30.0 } else { 0.0 }
    }

    /// A builder trained over `iterations` on records of `lobe`, drawn
    /// uniformly (as L / p with p = 1 / 4π), the structure refined between iterations.
    fn trained(iterations: u32, n: usize) -> DTreeBuilder {
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = TestRng::new(7);
        let mut b = DTreeBuilder::default();
        for it in 0..iterations {
            if it > 0 {
                b = b.refined(0.01);
            }
            for _ in 0..n {
                let d = square_to_dir(rng.next_2d());
                b.record(dir_to_square(d), lobe(axis, d) * 4.0 * std::f64::consts::PI);
            }
        }
        b
    }

    /// The table of the top levels gives the walk's bits, for shallow and
    /// deep trees, at random points, cell borders and the square's edges.
    #[test]
    fn top_table_gives_the_walks_bits() {
        // Radiance from one bright point over a dim floor: the tree deepens
        // by a few levels an iteration, well below the table.
        let mut rng = TestRng::new(5);
        let mut hot = DTreeBuilder::default();
        for it in 0..8 {
            if it > 0 {
                hot = hot.refined(0.01);
            }
            for _ in 0..2_000 {
                hot.record(Vec2::new(0.3, 0.7), 1.0);
                hot.record(rng.next_2d(), 0.01);
            }
        }
        let trees = [DTree::default(), trained(2, 2_000).freeze(), trained(6, 40_000).freeze(), hot.freeze()];
        // Levels walked to the leaf holding `p`.
        let depth = |t: &DTree, p: Vec2| {
            let (mut p, mut node, mut levels) = (p, 0usize, 1);
            loop {
                let q;
                (q, p) = quadrant(p);
                match t.nodes[node].child[q] {
                    0 => return levels,
                    c => (node, levels) = (c as usize, levels + 1),
                }
            }
        };
        let deepest = depth(&trees[3], Vec2::new(0.3, 0.7));
        assert!(deepest > 2 * TOP, "the hot point's leaf is at depth {deepest}");
        for t in &trees {
            let mut points: Vec<Vec2> = (0..50_000).map(|_| rng.next_2d()).collect();
            for i in 0..=64 {
                for v in [0.0, ONE_BELOW, 0.5, rng.next_2d().x] {
                    let e = (i as f32 / 64.0).min(ONE_BELOW);
                    points.extend([Vec2::new(e, v), Vec2::new(v, e)]);
                }
            }
            for p in points {
                // The walk from the root, level by level, without the table.
                let walked = t.walk(0, p, 1.0);
                assert_eq!(t.pdf_square(p).to_bits(), walked.to_bits(), "at {p} ({} nodes)", t.node_count());
            }
        }
    }

    #[test]
    fn atan2_is_within_an_ulp_at_pi() {
        let mut rng = TestRng::new(4);
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            let d = square_to_dir(rng.next_2d());
            // Axes and diagonals too, where the octant folds meet.
            let (y, x) = match i % 50 {
                0 => (0.0, d.x),
                1 => (d.y, 0.0),
                2 => (d.x, d.x),
                3 => (-d.x.abs(), d.x.abs()),
                _ => (d.y, d.x),
            };
            let exact = (y as f64).atan2(x as f64);
            let err = (atan2(y, x) as f64 - exact).abs();
            worst = worst.max(if x == 0.0 && y == 0.0 { 0.0 } else { err });
        }
        assert!(worst < 3e-7, "worst error {worst}");
    }

    #[test]
    fn square_map_round_trips() {
        let mut rng = TestRng::new(1);
        for _ in 0..10_000 {
            let p = rng.next_2d();
            let q = dir_to_square(square_to_dir(p));
            let d = (p - q).abs();
            // φ wraps at 1: positions near v = 0 and v = 1 are one direction.
            assert!(d.x < 1e-3 && (d.y < 1e-4 || d.y > 1.0 - 1e-4), "{p} -> {q}");
        }
    }

    #[test]
    fn refinement_follows_energy() {
        let b = trained(4, 20_000);
        let t = b.freeze();
        assert!(t.node_count() > 8, "the tree refined: {} nodes", t.node_count());
        // The density is high in the lobe and low outside it.
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        let inside = t.pdf(axis);
        let outside = t.pdf(-axis);
        assert!(inside > 50.0 * outside, "inside {inside}, outside {outside}");
        // A uniform density refines to the threshold's depth: quadrants of
        // 1/4, 1/16 and 1/64 of the total (> 1 %) split, those of 1/256 do not.
        let mut u = DTreeBuilder::default();
        let mut rng = TestRng::new(3);
        for _ in 0..100_000 {
            u.record(rng.next_2d(), 1.0);
        }
        assert_eq!(u.refined(0.01).node_count(), 1 + 4 + 16 + 64);
    }

    /// Exactly (the midpoint rule on a grid finer than the deepest leaf) on
    /// the square, and on the sphere within the quadrature's error.
    #[test]
    fn pdf_integrates_to_one() {
        for t in [DTree::default(), trained(3, 10_000).freeze(), trained(5, 40_000).freeze()] {
            let n = 1024;
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let p = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    sum += t.pdf_square(p) as f64;
                }
            }
            let square = sum / (n * n) as f64;
            assert!((square - 1.0).abs() < 1e-5, "∫ pdf = {square} on the square ({} nodes)", t.node_count());
            let sphere = integrate_over_sphere(|d| t.pdf(d) as f64);
            assert!((sphere - 1.0).abs() < 5e-3, "∫ pdf dω = {sphere} ({} nodes)", t.node_count());
        }
    }

    /// Directions drawn by `sample` follow `pdf` (chi-square), and the
    /// density `sample` returns is `pdf` at the direction drawn.
    #[test]
    fn sampling_matches_pdf() {
        let trees = [DTree::default(), trained(3, 10_000).freeze(), trained(6, 40_000).freeze()];
        let a = alpha(trees.len() + 1);
        for (i, t) in trees.iter().enumerate() {
            let p = chi2_test(
                200_000,
                11 + i as u64,
                |_, u| {
                    let (d, pdf) = t.sample(u);
                    let q = t.pdf(d);
                    assert!((pdf - q).abs() <= 1e-4 * q, "sample's pdf {pdf}, pdf() {q} at {d}");
                    Some(d)
                },
                |d| t.pdf(d) as f64,
            );
            assert!(p > a, "tree {i} ({} nodes): p = {p}", t.node_count());
        }
        // Power: a wrong density (the uniform one) is rejected for a refined tree.
        let t = &trees[2];
        let p = chi2_test(200_000, 99, |_, u| Some(t.sample(u).0), |_| 0.25 / std::f64::consts::PI);
        assert!(p < a, "a wrong pdf passed: p = {p}");
    }
}
