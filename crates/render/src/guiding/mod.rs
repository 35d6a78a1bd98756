//! Path guiding (Müller, Gross and Novák, "Practical Path Guiding for
//! Efficient Light-Transport Simulation", EGSR 2017): an SD-tree, a binary
//! tree over space whose leaves each hold a directional quadtree
//! ([`dtree`]) of the radiance arriving there, learnt from the paths of
//! earlier passes and sampled, mixed with the BSDF, at later ones.
//!
//! **Deterministic.** A pass's records ([`GuideRecord`]) are gathered per
//! tile in sample order and handed to [`Guide::update`] in tile order;
//! each spatial leaf takes its records in that order (leaves in parallel,
//! each alone), so the guide of pass k is a pure function of the scene,
//! the seed and the passes before k, whatever the threads.
//!
//! **Unbiased.** The guide only changes where directions are drawn: the
//! integrator weights a guided vertex by the mixture's density, which is
//! positive wherever the BSDF's is (see `integrator::path`).

pub mod dtree;
pub mod roulette;

use crate::geometry::Aabb;
use crate::simd::{Float, Int, Mask, V3};
use dtree::{dir_to_square, dir_to_square_lanes, DTree, DTreeBuilder, TOP_SIDE};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use roulette::PixelEstimate;

pub use dtree::MAX_DEPTH;

/// A quadtree quadrant holding more than this share of a leaf's radiance is
/// subdivided (the paper's ρ = 0.01).
pub const SUBDIVIDE_SHARE: f64 = 0.01;

/// A spatial leaf splits once an iteration gives it more than this many
/// records times √(2^iteration) (the paper's c = 12,000, for passes that
/// double in length).
pub const SPATIAL_THRESHOLD: f64 = 12_000.0;

/// One radiance estimate for training: at point `p`, radiance `value`
/// (channel mean, divided by the density the direction was drawn with)
/// arrived from the direction at square position `dir`
/// ([`dtree::dir_to_square`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuideRecord {
    /// Where the radiance arrived.
    pub p: Vec3,
    /// The direction it came from, on the square.
    pub dir: Vec2,
    /// L / p.
    pub value: f32,
}

impl GuideRecord {
    /// The record of radiance `radiance` (channel mean) from world
    /// direction `d` at `p`, drawn with density `pdf`; `None` unless all is finite.
    pub fn new(p: Vec3, d: Vec3, radiance: f32, pdf: f32) -> Option<GuideRecord> {
        let value = radiance / pdf;
        (value.is_finite() && value >= 0.0 && p.is_finite()).then(|| GuideRecord { p, dir: dir_to_square(d), value })
    }
}

/// The density guided directions are drawn from at one vertex: the
/// quadtree of the point's spatial leaf, folded onto one side of the
/// surface where the BSDF only reflects. There, a direction drawn on the
/// far side would be wasted (f = 0), so it is mirrored across the surface:
/// the density on the near side is p(ω) + p(ω mirrored), 0 on the far side.
#[derive(Debug, Clone, Copy)]
pub struct GuideDensity<'g> {
    /// The point's quadtree.
    pub tree: &'g DTree,
    /// The unit normal (world) of the side kept, when folded.
    pub fold: Option<Vec3>,
}

impl GuideDensity<'_> {
    /// A world direction drawn with `u` in [0, 1)², and its density
    /// ([`Self::pdf`], one quadtree descent fewer).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (d, pdf) = self.tree.sample(u);
        match self.fold {
            None => (d, pdf),
            Some(n) => {
                let m = mirror(d, n);
                (if d.dot(n) < 0.0 { m } else { d }, pdf + self.tree.pdf(m))
            }
        }
    }

    /// The density per steradian of drawing world direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match self.fold {
            None => self.tree.pdf(d),
            Some(n) if d.dot(n) < 0.0 => 0.0,
            Some(n) => self.tree.pdf(d) + self.tree.pdf(mirror(d, n)),
        }
    }
}

/// [`GuideDensity`] of a batch of lanes, each lane with its own quadtree
/// and fold ([`Guide::lanes`]): the lane form of its `sample` and `pdf`,
/// bitwise theirs per lane. Directions are mapped to the square and the
/// quadtrees' top tables read in lanes; the rare walk below a table and
/// the draws go one lane at a time.
pub struct GuideLanes<'g, F: Float> {
    /// Lane `l`'s quadtree.
    trees: [&'g DTree; 16],
    /// Per lane, where its tree's table starts in `tops`.
    base: F::Int,
    /// [`Guide`]'s `tops`.
    tops: &'g [f32],
    /// The unit normal (world) of the side kept, per lane, when folded.
    fold: Option<V3<F>>,
}

impl<F: Float> GuideLanes<'_, F> {
    /// Per lane of `lanes`, its quadtree's density per steradian at `d`
    /// (0 in the other lanes): `DTree::pdf`, its table looked up in lanes.
    #[inline]
    fn tree_pdf(&self, d: V3<F>, lanes: F::Mask) -> F {
        let zero = F::splat(0.0);
        let (u, v) = dir_to_square_lanes(d);
        let side = F::splat(TOP_SIDE as f32);
        let (sx, sy) = (u * side, v * side);
        // `pdf_square`'s cell: `s as usize` (NaN and negatives to 0), at most the last.
        let cell =
            |s: F| F::from_int(F::select(s.cmp_ge(zero), s, zero).min(F::splat((TOP_SIDE - 1) as f32)).to_int_trunc());
        let (cx, cy) = (cell(sx), cell(sy));
        let at = (cy * side + cx).to_int_trunc().shift_left(1).wrapping_add(self.base);
        let cell_pdf = F::gather_table(self.tops, at);
        let node = F::gather_table(self.tops, at.wrapping_add(F::Int::splat(1))).to_bits();
        let mut pdf = F::select(lanes, cell_pdf, zero);
        let walks = (lanes & !node.cmp_eq(F::Int::splat(0))).bitmask();
        if walks != 0 {
            // Below the table: `DTree::walk` on from the cell.
            let mut out = pdf.to_array();
            let (sx, sy, cx, cy) = (sx.to_array(), sy.to_array(), cx.to_array(), cy.to_array());
            let (node, cell_pdf) = (node.to_array(), cell_pdf.to_array());
            let mut m = walks;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                let p = Vec2::new(sx.as_ref()[l] - cx.as_ref()[l], sy.as_ref()[l] - cy.as_ref()[l]);
                out.as_mut()[l] = self.trees[l].walk(node.as_ref()[l] as usize, p, cell_pdf.as_ref()[l]);
            }
            pdf = F::from_array(out);
        }
        pdf * F::splat(0.25 / crate::math::PI)
    }

    /// [`GuideDensity::pdf`] of each lane's `d` in `need` (0 elsewhere).
    #[inline]
    pub fn pdf(&self, d: V3<F>, need: F::Mask) -> F {
        match self.fold {
            None => self.tree_pdf(d, need),
            Some(n) => {
                let need = need & !d.dot(n).cmp_lt(F::splat(0.0));
                self.tree_pdf(d, need) + self.tree_pdf(mirror_lanes(d, n), need)
            }
        }
    }

    /// [`GuideDensity::sample`] in the lanes of `picks` with numbers
    /// (`u0`, `u1`): the world directions and their densities (the other
    /// lanes' are meaningless). The quadtrees draw one lane at a time.
    #[inline]
    pub fn sample(&self, u0: F, u1: F, picks: F::Mask) -> (V3<F>, F) {
        let (u0, u1, bits) = (u0.to_array(), u1.to_array(), picks.bitmask());
        let mut drawn = [(Vec3::ZERO, 0.0f32); 16];
        for (l, d) in drawn.iter_mut().enumerate().take(F::WIDTH) {
            if bits >> l & 1 != 0 {
                *d = self.trees[l].sample(Vec2::new(u0.as_ref()[l], u1.as_ref()[l]));
            }
        }
        let d = V3::gather(|l| drawn[l].0);
        let pdf = crate::simd::gather::<F>(|l| drawn[l].1);
        match self.fold {
            None => (d, pdf),
            Some(n) => {
                let m = mirror_lanes(d, n);
                (V3::select(d.dot(n).cmp_lt(F::splat(0.0)), m, d), pdf + self.tree_pdf(m, picks))
            }
        }
    }
}

/// [`mirror`] of every lane, in glam's order per lane.
#[inline]
fn mirror_lanes<F: Float>(d: V3<F>, n: V3<F>) -> V3<F> {
    d - n * (F::splat(2.0) * d.dot(n))
}

/// `d` mirrored across the plane through the origin with unit normal `n`.
#[inline]
fn mirror(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// A spatial node: its two children (0: it is a leaf, `leaf` its index).
#[derive(Debug, Clone, Copy)]
struct SNode {
    child: [u32; 2],
    leaf: u32,
}

/// A region of space and what it learnt.
#[derive(Debug, Clone, Default)]
struct Leaf {
    /// The density guided directions are drawn from this pass.
    sampling: DTree,
    /// This pass's records.
    building: DTreeBuilder,
    /// Records this pass.
    records: u64,
}

/// The SD-tree: a binary tree over a cube around the scene, split at
/// midpoints along x, y, z in turn by depth.
#[derive(Debug, Clone)]
pub struct Guide {
    min: Vec3,
    size: f32,
    nodes: Vec<SNode>,
    leaves: Vec<Leaf>,
    /// Updates so far; the guide samples once there was one.
    iterations: u32,
    /// The image of the last training pass, for roulette ([`roulette`]).
    image: Option<PixelEstimate>,
    /// Every leaf's quadtree's top table in one array, leaf after leaf:
    /// per cell its density and its node's bits ([`Self::lanes`]).
    tops: Vec<f32>,
    /// `nodes` as bits, (first child, second child, leaf) a node
    /// ([`Self::leaves_of`]).
    snodes: Vec<f32>,
}

impl Guide {
    /// An untrained guide over the cube around `bounds` (slightly enlarged
    /// so that no surface lies on its faces).
    pub fn new(bounds: Aabb) -> Guide {
        let (lo, hi) = if bounds.min.cmple(bounds.max).all() && bounds.min.is_finite() && bounds.max.is_finite() {
            (bounds.min, bounds.max)
        } else {
            (Vec3::ZERO, Vec3::ONE)
        };
        let size = (hi - lo).max_element().max(1e-3) * 1.02;
        let centre = (lo + hi) * 0.5;
        let mut g = Guide {
            min: centre - Vec3::splat(size * 0.5),
            size,
            nodes: vec![SNode { child: [0; 2], leaf: 0 }],
            leaves: vec![Leaf::default()],
            iterations: 0,
            image: None,
            tops: Vec::new(),
            snodes: Vec::new(),
        };
        g.refresh_tables();
        g
    }

    /// Makes the lane tables from the tree and its leaves (after they change).
    fn refresh_tables(&mut self) {
        let cells = self.leaves.iter().flat_map(|l| l.sampling.top_cells());
        self.tops = cells.flat_map(|(pdf, node)| [pdf, f32::from_bits(node)]).collect();
        self.snodes = self.nodes.iter().flat_map(|n| [n.child[0], n.child[1], n.leaf].map(f32::from_bits)).collect();
    }

    /// [`Self::leaf_of`] of every lane's point (lanes past `F::WIDTH`: 0),
    /// the spatial tree walked in lanes: bitwise the same leaves.
    pub fn leaves_of<F: Float>(&self, p: V3<F>) -> [u32; 16] {
        let (zero, one, half) = (F::splat(0.0), F::splat(1.0), F::splat(0.5));
        let size = F::splat(self.size);
        // glam's clamp: max, then min (NaN to 0).
        let unit = |x: F, lo: f32| ((x - F::splat(lo)) / size).max(zero).min(one);
        let mut t = [unit(p.x, self.min.x), unit(p.y, self.min.y), unit(p.z, self.min.z)];
        let (mut node, mut leaf) = (F::Int::splat(0), F::Int::splat(0));
        let mut done = F::Mask::splat(false);
        for depth in 0.. {
            // A node's (first child, second child, leaf) at 3 node.
            let at = node.wrapping_mul(F::Int::splat(3));
            let c0 = F::gather_table(&self.snodes, at).to_bits();
            let is_leaf = c0.cmp_eq(F::Int::splat(0));
            let here = F::gather_table(&self.snodes, at.wrapping_add(F::Int::splat(2))).to_bits();
            leaf = F::Int::select(is_leaf & !done, here, leaf);
            done = done | is_leaf;
            if done.all() {
                break;
            }
            let x = &mut t[depth % 3];
            let hi = x.cmp_ge(half);
            *x = F::select(hi, *x * F::splat(2.0) - one, *x * F::splat(2.0));
            let c1 = F::gather_table(&self.snodes, at.wrapping_add(F::Int::splat(1))).to_bits();
            node = F::Int::select(done, node, F::Int::select(hi, c1, c0));
        }
        let leaf = leaf.to_array();
        std::array::from_fn(|l| leaf.as_ref().get(l).map_or(0, |&i| i as u32))
    }

    /// The lane form of the guide's density ([`GuideDensity`]) at lanes
    /// in spatial leaves `leaves` ([`Self::leaves_of`]), folded about the
    /// normals `fold` where given.
    pub fn lanes<F: Float>(&self, leaves: &[u32; 16], fold: Option<V3<F>>) -> GuideLanes<'_, F> {
        let mut base = <F::Int as Int>::Array::default();
        for (b, &l) in base.as_mut().iter_mut().zip(leaves) {
            // Within i32: a leaf's table is 512 floats, and far fewer leaves fit in memory.
            *b = (l as usize * 2 * TOP_SIDE * TOP_SIDE) as i32;
        }
        GuideLanes { trees: leaves.map(|l| self.leaf(l)), base: F::Int::from_array(base), tops: &self.tops, fold }
    }

    /// Whether the guide has learnt from a pass (before that it is not used).
    pub fn trained(&self) -> bool {
        self.iterations > 0
    }

    /// Passes learnt from.
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// The spatial leaf holding `p` (clamped into the cube). The axes
    /// x, y, z in turn, unrolled: an axis chosen at run time indexed the
    /// point through memory, and a guided lane vertex looks its leaf up.
    fn leaf_index(&self, p: Vec3) -> usize {
        let t = ((p - self.min) / self.size).clamp(Vec3::ZERO, Vec3::ONE);
        let mut t = [t.x, t.y, t.z];
        let mut node = 0usize;
        loop {
            for x in &mut t {
                let n = self.nodes[node];
                if n.child[0] == 0 {
                    return n.leaf as usize;
                }
                let hi = *x >= 0.5;
                *x = if hi { *x * 2.0 - 1.0 } else { *x * 2.0 };
                node = n.child[hi as usize] as usize;
            }
        }
    }

    /// The directional density at `p`.
    pub fn at(&self, p: Vec3) -> &DTree {
        &self.leaves[self.leaf_index(p)].sampling
    }

    /// The number of the spatial leaf holding `p`, for [`Self::leaf`]
    /// (`at(p)` is `leaf(leaf_of(p))`).
    pub fn leaf_of(&self, p: Vec3) -> u32 {
        self.leaf_index(p) as u32
    }

    /// The directional density of leaf `i` ([`Self::leaf_of`]).
    pub fn leaf(&self, i: u32) -> &DTree {
        &self.leaves[i as usize].sampling
    }

    /// Ends a pass: its `records` (in tile order, each tile's in sample
    /// order) become the guide of the next pass. Space is split where a
    /// leaf got more than `threshold` · √(2^passes so far) records (c,
    /// [`SPATIAL_THRESHOLD`] in the paper), and each leaf's quadtree refined
    /// where its radiance is large.
    pub fn update(&mut self, records: &[GuideRecord], threshold: f64) {
        // Records grouped by leaf, keeping their order.
        let leaf_of: Vec<u32> = records.par_iter().map(|r| self.leaf_index(r.p) as u32).collect();
        let (start, order) = crate::math::counting_order(leaf_of.iter().map(|&l| l as usize), self.leaves.len());
        self.leaves.par_iter_mut().enumerate().for_each(|(l, leaf)| {
            for &i in &order[start[l]..start[l + 1]] {
                let r = &records[i as usize];
                leaf.building.record(r.dir, r.value as f64);
            }
            let n = (start[l + 1] - start[l]) as u64;
            leaf.records = leaf.records.saturating_add(n);
            leaf.sampling = leaf.building.freeze_counted(n);
        });
        // Space: leaves with many records split (their children share the
        // records, half each, and keep what the parent learnt).
        let threshold = threshold * 2f64.powi(self.iterations as i32).sqrt();
        let mut stack: Vec<(usize, u32)> = vec![(0, 0)];
        while let Some((node, depth)) = stack.pop() {
            let n = self.nodes[node];
            if n.child[0] != 0 {
                stack.extend(n.child.iter().map(|&c| (c as usize, depth + 1)));
                continue;
            }
            let leaf = &mut self.leaves[n.leaf as usize];
            if (leaf.records as f64) <= threshold || depth >= 60 {
                continue;
            }
            leaf.records /= 2;
            let copy = leaf.clone();
            let c = self.nodes.len() as u32;
            self.leaves.push(copy);
            self.nodes.push(SNode { child: [0; 2], leaf: n.leaf });
            self.nodes.push(SNode { child: [0; 2], leaf: self.leaves.len() as u32 - 1 });
            self.nodes[node].child = [c, c + 1];
            stack.extend([(c as usize, depth + 1), (c as usize + 1, depth + 1)]);
        }
        // Directions: the next pass records on a structure refined by this one's radiance.
        self.leaves.par_iter_mut().for_each(|leaf| {
            leaf.building = leaf.building.refined(SUBDIVIDE_SHARE);
            leaf.records = 0;
        });
        self.iterations += 1;
        self.refresh_tables();
    }

    /// Sets the image that roulette compares a path's expected share with:
    /// the image of the training pass just learnt from (`None`: black).
    pub fn set_image(&mut self, image: Option<PixelEstimate>) {
        self.image = image;
    }

    /// The value of pixel `global` (full-image coordinates) in the last
    /// training pass's image, for roulette; 0 when there is none.
    #[inline]
    pub fn pixel_estimate(&self, global: (u32, u32)) -> f32 {
        self.image.as_ref().map_or(0.0, |i| i.at(global))
    }

    /// Appends the guide to `out` (little-endian), for a checkpoint: a
    /// resumed render goes on with the very guide it stopped with.
    pub fn encode(&self, out: &mut Vec<u8>) {
        for v in [self.min.x, self.min.y, self.min.z, self.size] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.iterations.to_le_bytes());
        out.extend_from_slice(&(self.nodes.len() as u32).to_le_bytes());
        for n in &self.nodes {
            for v in [n.child[0], n.child[1], n.leaf] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.extend_from_slice(&(self.leaves.len() as u32).to_le_bytes());
        for l in &self.leaves {
            l.sampling.encode(out);
            l.building.encode(out);
            out.extend_from_slice(&l.records.to_le_bytes());
        }
        out.push(self.image.is_some() as u8);
        if let Some(i) = &self.image {
            i.encode(out);
        }
    }

    /// Reads a guide [`Self::encode`] wrote, from `bytes[*at..]`, moving
    /// `at` past it. Damaged bytes are an error saying what is wrong, never
    /// a panic or a tree whose descent would not end.
    pub fn decode(bytes: &[u8], at: &mut usize) -> Result<Guide, String> {
        let mut r = dtree::Bytes { b: bytes, at: *at };
        let (x, y, z, size) = (r.f32()?, r.f32()?, r.f32()?, r.f32()?);
        let min = Vec3::new(x, y, z);
        if !(min.is_finite() && size.is_finite() && size > 0.0) {
            return Err(format!("the guide's cube at {min} of size {size}"));
        }
        let iterations = r.u32()?;
        let n = r.count(12)?;
        let mut nodes = Vec::with_capacity(n);
        for _ in 0..n {
            nodes.push(SNode { child: [r.u32()?, r.u32()?], leaf: r.u32()? });
        }
        let leaves_n = r.count(48)?;
        if n == 0 || leaves_n == 0 {
            return Err("a guide without nodes or leaves".into());
        }
        for (i, s) in nodes.iter().enumerate() {
            let inner = s.child.map(|c| c != 0);
            let ok = match inner {
                [false, false] => (s.leaf as usize) < leaves_n,
                [true, true] => s.child.iter().all(|&c| c as usize > i && (c as usize) < n),
                _ => false,
            };
            if !ok {
                return Err(format!("spatial node {i} ({:?}, leaf {}) of {n}", s.child, s.leaf));
            }
        }
        let mut leaves = Vec::with_capacity(leaves_n);
        for _ in 0..leaves_n {
            let sampling = DTree::decode(&mut r)?;
            let building = DTreeBuilder::decode(&mut r)?;
            leaves.push(Leaf { sampling, building, records: r.u64()? });
        }
        let image = match r.take(1)?[0] {
            0 => None,
            1 => Some(PixelEstimate::decode(&mut r)?),
            f => return Err(format!("a pixel-estimate flag of {f}")),
        };
        *at = r.at;
        let mut g = Guide { min, size, nodes, leaves, iterations, image, tops: Vec::new(), snodes: Vec::new() };
        g.refresh_tables();
        Ok(g)
    }

    /// Spatial leaves and quadtree nodes (sampling trees), for reports.
    pub fn size(&self) -> (usize, usize) {
        (self.leaves.len(), self.leaves.iter().map(|l| l.sampling.node_count()).sum())
    }

    /// Bytes the guide holds (both trees of every leaf, the sampling tree's
    /// table, and the lane lookups' copies of the tables and the spatial tree).
    pub fn memory(&self) -> usize {
        let per_node = 16 + 16 + 16 + 32;
        self.nodes.len() * std::mem::size_of::<SNode>()
            + self
                .leaves
                .iter()
                .map(|l| {
                    std::mem::size_of::<Leaf>()
                        + per_node * l.sampling.node_count().max(l.building.node_count())
                        + l.sampling.table_bytes()
                })
                .sum::<usize>()
            + (self.tops.len() + self.snodes.len()) * std::mem::size_of::<f32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::TestRng;

    fn unit_box() -> Aabb {
        Aabb { min: Vec3::ZERO, max: Vec3::ONE }
    }

    /// Radiance from +z in the half x < 0.5, from −z in the other.
    fn records(n: usize, seed: u64) -> Vec<GuideRecord> {
        let mut rng = TestRng::new(seed);
        (0..n)
            .map(|_| {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let d = dtree::square_to_dir(rng.next_2d());
                let bright = if p.x < 0.5 { d.z > 0.8 } else { d.z < -0.8 };
                let l = if bright { 10.0 } else { 0.1 };
                GuideRecord::new(p, d, l, 0.25 / crate::math::PI).unwrap()
            })
            .collect()
    }

    /// The lane forms are bitwise the scalar ones on every lane width: the
    /// square map (on directions of special values too: zeros of both signs,
    /// axes, NaN, infinities, components past 1), and a trained guide's
    /// densities and draws, folded and not, each lane with its own leaf.
    #[test]
    fn lanes_are_bitwise_the_scalar_guide() {
        use crate::simd::check::{each_simd, same, specials, Visit};
        let mut g = Guide::new(unit_box());
        for it in 0..3 {
            // `records`, and radiance from a narrow cone, which the trees refine below their tables.
            let mut rs = records(20_000 << it, 40 + it as u64);
            for r in &mut rs {
                if dtree::square_to_dir(r.dir).dot(Vec3::new(0.6, 0.0, 0.8)) > 0.999 {
                    r.value *= 1e4;
                }
            }
            g.update(&rs, SPATIAL_THRESHOLD);
        }
        assert!(g.leaves.len() > 1, "the test wants lanes in different leaves");
        // More nodes than the levels of the top table hold: lookups walk below it.
        let top_nodes = (0..dtree::TOP).map(|k| 4usize.pow(k)).sum::<usize>();
        assert!(g.leaves.iter().any(|l| l.sampling.node_count() > top_nodes), "no tree deeper than its table");
        struct V<'a> {
            g: &'a Guide,
            checked: usize,
        }
        impl Visit for V<'_> {
            fn visit<F: Float>(&mut self) {
                let w = F::WIDTH;
                let sp = specials(&[1.0, -1.0, 2.0, -2.0, f32::NAN, f32::INFINITY, -f32::INFINITY]);
                let mut rng = TestRng::new(11);
                let pick = |rng: &mut TestRng| sp[(rng.next_f32() * sp.len() as f32) as usize % sp.len()];
                let eq =
                    |a: f32, b: f32, what: &str| assert!(same(a, b, false), "{what} on {}: {a:e} vs {b:e}", F::NAME);
                for round in 0..600 {
                    // Unit directions (most rounds), or triples of special values.
                    let d: Vec<Vec3> = (0..w)
                        .map(|_| match round % 3 {
                            2 => Vec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng)),
                            _ => dtree::square_to_dir(rng.next_2d()),
                        })
                        .collect();
                    let dl = V3::<F>::gather(|l| d[l]);
                    let (u, v) = dir_to_square_lanes(dl);
                    for l in 0..w {
                        let want = dir_to_square(d[l]);
                        eq(u.to_array().as_ref()[l], want.x, "u");
                        eq(v.to_array().as_ref()[l], want.y, "v");
                    }
                    if round % 3 == 2 {
                        continue;
                    }
                    // Lanes in random leaves, folded about random normals or not.
                    let leaves: [u32; 16] = std::array::from_fn(|_| {
                        self.g.leaf_of(Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
                    });
                    // The spatial lookup in lanes, on points in and out of the cube.
                    let pts: Vec<Vec3> =
                        (0..w).map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - 0.1).collect();
                    let found = self.g.leaves_of(V3::<F>::gather(|l| pts[l]));
                    for l in 0..w {
                        assert_eq!(found[l], self.g.leaf_of(pts[l]), "leaf of {} on {}", pts[l], F::NAME);
                    }
                    let normals: Vec<Vec3> = (0..w).map(|_| dtree::square_to_dir(rng.next_2d())).collect();
                    let folded = round % 2 == 0;
                    let lanes = self.g.lanes::<F>(&leaves, folded.then(|| V3::gather(|l| normals[l])));
                    let scalar =
                        |l: usize| GuideDensity { tree: self.g.leaf(leaves[l]), fold: folded.then_some(normals[l]) };
                    let need = (rng.next_f32() * (1u64 << w) as f32) as u32 & ((1u64 << w) - 1) as u32;
                    let mask = crate::simd::gather::<F>(|l| (need >> l & 1) as f32).cmp_ne(F::splat(0.0));
                    let pdf = lanes.pdf(dl, mask).to_array();
                    let (u0, u1): (Vec<f32>, Vec<f32>) = (0..w).map(|_| (rng.next_f32(), rng.next_f32())).unzip();
                    let (drawn, drawn_pdf) =
                        lanes.sample(crate::simd::gather(|l| u0[l]), crate::simd::gather(|l| u1[l]), mask);
                    let (drawn, drawn_pdf) = (drawn.to_lanes(), drawn_pdf.to_array());
                    for l in 0..w {
                        let want = if need >> l & 1 != 0 { scalar(l).pdf(d[l]) } else { 0.0 };
                        eq(pdf.as_ref()[l], want, "pdf");
                        if need >> l & 1 != 0 {
                            let (wd, wp) = scalar(l).sample(Vec2::new(u0[l], u1[l]));
                            for k in 0..3 {
                                eq(drawn[l][k], wd[k], "sampled direction");
                            }
                            eq(drawn_pdf.as_ref()[l], wp, "sampled density");
                        }
                        self.checked += 1;
                    }
                }
            }
        }
        let mut v = V { g: &g, checked: 0 };
        let names = each_simd(&mut v);
        // The scalar instance too: the lane code's own f32 form.
        v.visit::<f32>();
        assert!(v.checked > 0);
        println!("guide lanes bitwise the scalar guide on {names:?} and f32: {} lanes", v.checked);
    }

    /// Folded onto a hemisphere, the density is 0 on the far side, sums to
    /// 1 on the near one, and directions drawn follow it (chi-square).
    #[test]
    fn folded_density_matches_its_samples() {
        use crate::testing::chi2::{alpha, chi2_test};
        let mut g = Guide::new(unit_box());
        for it in 0..3 {
            g.update(&records(20_000 << it, 40 + it as u64), SPATIAL_THRESHOLD);
        }
        let p = Vec3::new(0.2, 0.5, 0.5);
        let normals = [Vec3::Z, Vec3::new(0.3, -0.9, 0.2).normalize(), -Vec3::Z];
        let a = alpha(normals.len());
        for (i, n) in normals.into_iter().enumerate() {
            let dens = GuideDensity { tree: g.at(p), fold: Some(n) };
            // ∫ over the sphere as 4π ∫ over the square, midpoint rule on a
            // grid finer than the tree's leaves (which it then integrates
            // exactly): what error remains is along the fold's edge.
            let m = 2048;
            let mut sum = 0.0f64;
            for i in 0..m {
                for j in 0..m {
                    let q = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                    sum += dens.pdf(dtree::square_to_dir(q)) as f64;
                }
            }
            let total = sum * 4.0 * crate::math::PI as f64 / (m * m) as f64;
            assert!((total - 1.0).abs() < 2e-4, "∫ folded pdf dω = {total} (normal {n})");
            assert_eq!(dens.pdf(-n), 0.0);
            // The density `sample` returns is `pdf`'s, except where a
            // direction rounds onto a quadtree cell's edge on its way to the
            // sphere and back (mirroring moves it once more): rare.
            let off = std::cell::Cell::new(0u32);
            let pv = chi2_test(
                200_000,
                50 + i as u64,
                |_, u| {
                    let (d, pdf) = dens.sample(u);
                    let q = dens.pdf(d);
                    if (pdf - q).abs() > 1e-4 * q {
                        off.set(off.get() + 1);
                    }
                    Some(d)
                },
                |d| dens.pdf(d) as f64,
            );
            assert!(pv > a, "normal {n}: p = {pv}");
            assert!(off.get() < 200, "normal {n}: sample's density is not pdf's for {} of 200,000", off.get());
            // The light from +z is kept when folding onto −z: mirrored, it comes from −z.
            if i == 2 {
                assert!(dens.pdf(-Vec3::Z) > 20.0 * dens.pdf(-Vec3::new(1.0, 0.0, 0.1).normalize()));
            }
        }
    }

    #[test]
    fn learns_where_light_comes_from() {
        let mut g = Guide::new(unit_box());
        assert!(!g.trained());
        for it in 0..4 {
            g.update(&records(40_000 << it, it as u64), SPATIAL_THRESHOLD);
        }
        let (leaves, nodes) = g.size();
        assert!(leaves >= 2 && nodes > 2 * 21, "{leaves} leaves, {nodes} nodes");
        let (left, right) = (Vec3::new(0.2, 0.5, 0.5), Vec3::new(0.8, 0.5, 0.5));
        let (up, down) = (Vec3::Z, -Vec3::Z);
        assert!(g.at(left).pdf(up) > 20.0 * g.at(left).pdf(down));
        assert!(g.at(right).pdf(down) > 20.0 * g.at(right).pdf(up));
        println!("guide: {leaves} leaves, {nodes} nodes, {} KiB", g.memory() / 1024);
    }

    /// The spatial lookup splits along x, y, z in turn by depth: each leaf
    /// found is the one a walk that picks the axis by depth mod 3 finds,
    /// inside the cube and clamped outside it.
    #[test]
    fn leaf_lookup_cycles_the_axes() {
        let mut g = Guide::new(unit_box());
        for it in 0..4 {
            g.update(&records(40_000 << it, 60 + it as u64), SPATIAL_THRESHOLD);
        }
        let deepest = |p: Vec3| {
            let mut t = ((p - g.min) / g.size).clamp(Vec3::ZERO, Vec3::ONE);
            let (mut node, mut depth) = (0usize, 0usize);
            loop {
                let n = g.nodes[node];
                if n.child[0] == 0 {
                    return (n.leaf as usize, depth);
                }
                let hi = t[depth % 3] >= 0.5;
                t[depth % 3] = if hi { t[depth % 3] * 2.0 - 1.0 } else { t[depth % 3] * 2.0 };
                (node, depth) = (n.child[hi as usize] as usize, depth + 1);
            }
        };
        let mut rng = TestRng::new(8);
        let mut max_depth = 0;
        for _ in 0..20_000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - Vec3::splat(0.1);
            let (leaf, depth) = deepest(p);
            max_depth = max_depth.max(depth);
            assert_eq!(g.leaf_index(p), leaf, "at {p}");
        }
        assert!(max_depth > 3, "the tree splits past one round of the axes: depth {max_depth}");
    }

    /// Each leaf's tree also estimates the radiance arriving from a
    /// direction (Φ · pdf, for roulette): Φ, the mean record, is ∫ L_i dω,
    /// and Φ · pdf averaged over a region of directions is the radiance
    /// recorded there.
    #[test]
    fn estimates_incident_radiance() {
        let mut g = Guide::new(unit_box());
        for it in 0..5 {
            g.update(&records(40_000 << it, 20 + it as u64), SPATIAL_THRESHOLD);
        }
        // Per side: 10 from a cap of 2π (1 − 0.8) sr, 0.1 from the rest.
        let cap = 2.0 * std::f64::consts::PI * 0.2;
        let flux = 10.0 * cap + 0.1 * (4.0 * std::f64::consts::PI - cap);
        let leaves = g.size().0 as f64;
        // A leaf's last pass gave it about 640,000 / leaves records, spread
        // uniformly over the sphere.
        let per_leaf = 640_000.0 / leaves;
        // The mean of Φ · pdf over the directions with z in [lo, hi], on a
        // fine grid of the cylindrical map (uniform in z and φ is uniform
        // in solid angle).
        let mean = |t: &DTree, lo: f32, hi: f32| {
            let n = 200;
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let z = lo + (hi - lo) * (i as f32 + 0.5) / n as f32;
                    let phi = 2.0 * crate::math::PI * (j as f32 + 0.5) / n as f32;
                    let r = (1.0 - z * z).sqrt();
                    let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    sum += t.radiance(t.pdf(d)) as f64;
                }
            }
            sum / (n * n) as f64
        };
        for p in [Vec3::new(0.2, 0.5, 0.5), Vec3::new(0.8, 0.3, 0.6)] {
            let t = g.at(p);
            // Records of L / p: a tenth 126 (the cap), the rest 1.26; their
            // standard deviation is 37.3.
            let se = 37.3 / per_leaf.sqrt();
            assert!((t.flux() as f64 - flux).abs() < 5.0 * se, "at {p}: Φ = {} against {flux}", t.flux());
            // The cap's inner part, z > 0.85 (the square's x > 0.925), lies
            // in quadtree cells inside the cap: a cell holding over 1 % of
            // the radiance is split, so the cap's cells are 1/32 wide and the
            // one at its edge ends at x = 0.906. 7.5 % of the records fall
            // there, each of the same value: the mean's relative error is
            // 1 / √n. The dark side's cells hold no cap.
            let (bright, dark) = if p.x < 0.5 {
                (mean(t, 0.85, 1.0), mean(t, -1.0, -0.85))
            } else {
                (mean(t, -1.0, -0.85), mean(t, 0.85, 1.0))
            };
            let rel = 1.0 / (0.075 * per_leaf).sqrt();
            assert!((bright - 10.0).abs() < 5.0 * rel * 10.0, "at {p}: L_i = {bright} from the cap, 10 expected");
            assert!((dark - 0.1).abs() < 5.0 * rel * 0.1, "at {p}: L_i = {dark} from below, 0.1 expected");
        }
        assert_eq!(Guide::new(unit_box()).at(Vec3::ZERO).flux(), 0.0, "untrained: unknown");
    }

    /// A guide read back from its bytes guides exactly as the original;
    /// damaged bytes are refused, never a panic.
    #[test]
    fn encodes_and_decodes() {
        let mut g = Guide::new(unit_box());
        for it in 0..3 {
            g.update(&records(20_000 << it, 60 + it as u64), SPATIAL_THRESHOLD);
        }
        g.set_image(PixelEstimate::new((0, 0), 2, 1, vec![1.0, 3.0]));
        let mut bytes = vec![7u8; 3];
        g.encode(&mut bytes);
        let mut at = 3;
        let h = Guide::decode(&bytes, &mut at).unwrap();
        assert_eq!(at, bytes.len());
        let mut rng = TestRng::new(8);
        for _ in 0..1000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let u = rng.next_2d();
            assert_eq!(g.at(p).sample(u).0, h.at(p).sample(u).0);
            assert_eq!(g.at(p).pdf(Vec3::Z).to_bits(), h.at(p).pdf(Vec3::Z).to_bits());
            assert_eq!(g.at(p).flux().to_bits(), h.at(p).flux().to_bits());
        }
        assert_eq!(h.pixel_estimate((1, 0)), 3.0);
        // Learning goes on identically from the decoded guide.
        let (mut g2, mut h2) = (g.clone(), h);
        g2.update(&records(30_000, 99), SPATIAL_THRESHOLD);
        h2.update(&records(30_000, 99), SPATIAL_THRESHOLD);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        g2.encode(&mut a);
        h2.encode(&mut b);
        assert_eq!(a, b);
        // Truncated anywhere, or with a byte changed, it is refused or reads
        // as some valid guide; it never panics.
        for cut in (0..bytes.len() - 3).step_by(97) {
            assert!(Guide::decode(&bytes[..3 + cut], &mut 3).is_err(), "cut at {cut}");
        }
        let mut rng = TestRng::new(9);
        for _ in 0..2000 {
            let mut bad = bytes.clone();
            let i = 3 + (rng.next_f32() * (bad.len() - 3) as f32) as usize % (bad.len() - 3);
            bad[i] = (rng.next_f32() * 256.0) as u8;
            if let Ok(h) = Guide::decode(&bad, &mut 3) {
                let _ = h.at(Vec3::splat(0.5)).sample(Vec2::new(0.3, 0.7));
            }
        }
    }

    /// The same records give the same guide, whichever the threads.
    #[test]
    fn update_is_deterministic() {
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut g = Guide::new(unit_box());
                for it in 0..3 {
                    g.update(&records(30_000 << it, 10 + it as u64), SPATIAL_THRESHOLD);
                }
                g
            })
        };
        let (a, b) = (build(1), build(3));
        let mut rng = TestRng::new(5);
        for _ in 0..1000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let d = dtree::square_to_dir(rng.next_2d());
            assert_eq!(a.at(p).pdf(d).to_bits(), b.at(p).pdf(d).to_bits());
        }
    }
}
