//! Piecewise-constant 2D distribution over [0, 1)² (pbrt-v3 §13.6.7): a
//! marginal distribution over rows (the row sums), then the conditional
//! distribution over the columns of the chosen row.

use super::distrib1d::alias_pick;
use super::Distribution1D;
use crate::math::fast;
use crate::simd::{Float, Int, Mask as _};
use glam::Vec2;

/// Density proportional to a `width` × `height` grid of non-negative cell
/// weights; x runs along columns, y along rows (row 0 at y = 0).
///
/// The rows' alias tables and the cells' densities lie in one array in
/// cell order, so a sample is a row pick and a column pick with no pointer
/// to follow in between (the environment map samples one per light sample).
#[derive(Debug, Clone)]
pub struct Distribution2D {
    /// Per cell: its row's alias bucket (share kept, column taking the
    /// rest) and its density (weight / mean weight; 0 in a row of zero weight).
    cells: Vec<Cell>,
    /// Distribution over rows, weighted by the row sums.
    marginal: Distribution1D,
    /// The marginal's alias table as floats, (share kept, the bits of the
    /// row taking the rest) per bucket, for gathers in lanes.
    marginal_floats: Vec<f32>,
    width: usize,
    height: usize,
}

/// Floats per [`Cell`] (`keep` and `other` first, as `alias_pick_lanes`
/// reads them)...
const CELL_FLOATS: i32 = 3;
/// ...and where its density is among them.
const CELL_PDF: i32 = 2;

#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct Cell {
    keep: f32,
    other: u32,
    pdf: f32,
}

impl Distribution2D {
    /// `weights` is row-major, row 0 first. Returns `None` when the sizes do
    /// not match, no weight is positive, or a weight is negative or not finite.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Option<Distribution2D> {
        if width == 0 || height == 0 || weights.len() != width * height {
            return None;
        }
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        let conditional: Vec<_> = weights.chunks_exact(width).map(Distribution1D::new).collect();
        let row_sums: Vec<f32> = conditional.iter().map(|c| c.as_ref().map_or(0.0, |c| c.total as f32)).collect();
        let marginal = Distribution1D::new(&row_sums)?;
        let inv_mean = ((width * height) as f64 / marginal.total) as f32;
        let mut cells = Vec::with_capacity(width * height);
        for c in &conditional {
            match c {
                Some(c) => cells.extend(c.alias().iter().zip(&c.func).map(|(&(keep, other), &f)| Cell {
                    keep,
                    other,
                    pdf: f * inv_mean,
                })),
                // Never sampled (the marginal skips the row).
                None => cells.extend((0..width).map(|j| Cell { keep: 1.0, other: j as u32, pdf: 0.0 })),
            }
        }
        let marginal_floats =
            marginal.alias().iter().flat_map(|&(keep, other)| [keep, f32::from_bits(other)]).collect();
        Some(Distribution2D { cells, marginal, marginal_floats, width, height })
    }

    /// The cells as one slice of floats, [`CELL_FLOATS`] per cell (`other`
    /// as its bits).
    #[inline(always)]
    fn cell_floats(&self) -> &[f32] {
        const { assert!(std::mem::size_of::<Cell>() == 4 * CELL_FLOATS as usize && std::mem::align_of::<Cell>() == 4) };
        // SAFETY: `Cell` is `#[repr(C)]` of three 4-byte fields with no
        // padding (asserted above), and every bit pattern (`other`'s too)
        // is a valid f32; `n` cells are `3 n` floats of the same
        // allocation, borrowed as long as `self`.
        unsafe {
            std::slice::from_raw_parts(self.cells.as_ptr().cast::<f32>(), CELL_FLOATS as usize * self.cells.len())
        }
    }

    /// Samples a point p ∈ [0, 1)² (p.x along columns, p.y along rows) and
    /// returns it with its density w.r.t. area on the unit square (cell
    /// weight / mean weight).
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (row, _, uy) = self.marginal.sample_discrete(u.y);
        let cells = &self.cells[row * self.width..][..self.width];
        let (col, ux) = alias_pick(u.x, self.width, |b| (cells[b].keep, cells[b].other));
        let p = Vec2::new(point_in_cell(col, ux, self.width), point_in_cell(row, uy, self.height));
        (p, cells[col].pdf)
    }

    /// Density at `p` w.r.t. area on the unit square (0 outside [0, 1]²).
    pub fn pdf(&self, p: Vec2) -> f32 {
        if !(0.0..=1.0).contains(&p.x) || !(0.0..=1.0).contains(&p.y) {
            return 0.0;
        }
        let col = fast::index(p.x * self.width as f32).min(self.width - 1);
        let row = fast::index(p.y * self.height as f32).min(self.height - 1);
        self.cells[row * self.width + col].pdf
    }

    /// [`Self::sample`] of `F::WIDTH` pairs of numbers, bitwise lane by
    /// lane: (p.x, p.y, density), the tables read by gathers.
    #[inline(always)]
    pub fn sample_lanes<F: Float>(&self, ux: F, uy: F) -> (F, F, F) {
        let (row, uy) = alias_pick_lanes(uy, F::splat(self.height as f32), &self.marginal_floats, F::Int::splat(0), 2);
        let cells = self.cell_floats();
        let start = row.wrapping_mul(F::Int::splat(self.width as i32));
        let (col, ux) = alias_pick_lanes(
            ux,
            F::splat(self.width as f32),
            cells,
            start.wrapping_mul(F::Int::splat(CELL_FLOATS)),
            CELL_FLOATS,
        );
        let pdf = F::gather_table(cells, self.cell_float(start.wrapping_add(col), CELL_PDF));
        (point_in_cell_lanes(col, ux, self.width), point_in_cell_lanes(row, uy, self.height), pdf)
    }

    /// [`Self::pdf`] of `F::WIDTH` points, bitwise lane by lane.
    #[inline(always)]
    pub fn pdf_lanes<F: Float>(&self, x: F, y: F) -> F {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let inside = x.cmp_ge(zero) & x.cmp_le(one) & y.cmp_ge(zero) & y.cmp_le(one);
        let col = index_lanes(x * F::splat(self.width as f32), self.width - 1);
        let row = index_lanes(y * F::splat(self.height as f32), self.height - 1);
        let cell = row.wrapping_mul(F::Int::splat(self.width as i32)).wrapping_add(col);
        let pdf = F::gather_table(self.cell_floats(), self.cell_float(cell, CELL_PDF));
        F::select(inside, pdf, zero)
    }

    /// Where field `field` of each lane's cell `cell` is in [`Self::cell_floats`].
    #[inline(always)]
    fn cell_float<I: Int>(&self, cell: I, field: i32) -> I {
        cell.wrapping_mul(I::splat(CELL_FLOATS)).wrapping_add(I::splat(field))
    }
}

/// `fast::index(x).min(max)` in lanes, for x < 2³¹ or NaN (both give 0
/// below, as `x as i32` does for NaN).
#[inline(always)]
pub(crate) fn index_lanes<F: Float>(x: F, max: usize) -> F::Int {
    index_lanes_to(x, F::Int::splat(max as i32))
}

/// [`index_lanes`] with a bound per lane.
#[inline(always)]
fn index_lanes_to<F: Float>(x: F, max: F::Int) -> F::Int {
    let zero = F::Int::splat(0);
    let i = x.to_int_trunc();
    let i = F::Int::select(i.cmp_lt(zero), zero, i);
    F::Int::select(i.cmp_gt(max), max, i)
}

/// `alias_pick` in lanes, bitwise lane by lane: lane `l` picks among
/// `n[l]` buckets (a whole number below 2²⁴ as a float, so that `u n` is
/// `alias_pick`'s product), its bucket `b` at float `start[l] + stride b`
/// of `table` (the share kept), the bits of the item taking the rest right
/// after it.
#[inline(always)]
pub(crate) fn alias_pick_lanes<F: Float>(u: F, n: F, table: &[f32], start: F::Int, stride: i32) -> (F::Int, F) {
    let x = u * n;
    let b = index_lanes_to(x, n.to_int_trunc().wrapping_sub(F::Int::splat(1)));
    let f = x - F::from_int(b);
    let at = start.wrapping_add(b.wrapping_mul(F::Int::splat(stride)));
    let keep = F::gather_table(table, at);
    let other = F::gather_table(table, at.wrapping_add(F::Int::splat(1))).to_bits();
    let own = f.cmp_lt(keep);
    let one = F::splat(1.0);
    let u_re = F::select(own, f / keep, (f - keep) / (one - keep));
    // As f32::clamp (NaN passes through).
    let u_re = F::splat(1.0 - f32::EPSILON / 2.0).min(F::splat(0.0).max(u_re));
    (F::Int::select(own, b, other), u_re)
}

/// `point_in_cell` in lanes: each lane steps until it maps back to its cell.
#[inline(always)]
fn point_in_cell_lanes<F: Float>(i: F::Int, t: F, n: usize) -> F {
    let cell = |x: F| index_lanes(x * F::splat(n as f32), i32::MAX as usize);
    let mut x = (F::from_int(i) + t) / F::splat(n as f32);
    loop {
        let above = cell(x).cmp_gt(i);
        if !above.any() {
            break;
        }
        x = F::select(above, F::from_bits(x.to_bits().wrapping_sub(F::Int::splat(1))), x);
    }
    loop {
        let below = cell(x).cmp_lt(i);
        if !below.any() {
            break;
        }
        x = F::select(below, F::from_bits(x.to_bits().wrapping_add(F::Int::splat(1))), x);
    }
    x
}

/// (i + t) / n, nudged by rounding steps so that it maps back to cell i
/// (as `pdf` computes cells), and so stays below 1.
fn point_in_cell(i: usize, t: f32, n: usize) -> f32 {
    let cell = |x: f32| fast::index(x * n as f32);
    let mut x = (i as f32 + t) / n as f32;
    while cell(x) > i {
        x = f32::from_bits(x.to_bits() - 1);
    }
    while cell(x) < i {
        x = f32::from_bits(x.to_bits() + 1);
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::{hash_words, to_unit_f32};
    use crate::simd::gather;
    use statrs::distribution::{ChiSquared, ContinuousCDF};

    /// 5 × 4 grid with an empty row (1) and an empty column (3).
    const W: usize = 5;
    const H: usize = 4;
    #[rustfmt::skip]
    const WEIGHTS: [f32; W * H] = [
        1.0, 2.0, 0.5, 0.0, 4.0,
        0.0, 0.0, 0.0, 0.0, 0.0,
        3.0, 0.1, 7.0, 0.0, 1.0,
        0.2, 9.0, 1.0, 0.0, 2.5,
    ];

    fn random_u(seed: u64, i: u64) -> Vec2 {
        Vec2::new(to_unit_f32(hash_words(&[seed, i, 0])), to_unit_f32(hash_words(&[seed, i, 1])))
    }

    #[test]
    fn pdf_integrates_to_one_and_is_weight_over_mean() {
        let d = Distribution2D::new(&WEIGHTS, W, H).unwrap();
        let mean = WEIGHTS.iter().sum::<f32>() / (W * H) as f32;
        // Midpoint rule on a sub-grid aligned with the cells: exact for a piecewise-constant pdf.
        let n = 40;
        let mut integral = 0.0f64;
        for a in 0..n * H {
            for b in 0..n * W {
                let p = Vec2::new((b as f32 + 0.5) / (n * W) as f32, (a as f32 + 0.5) / (n * H) as f32);
                let pdf = d.pdf(p);
                assert!((pdf - WEIGHTS[(a / n) * W + b / n] / mean).abs() < 1e-5);
                integral += pdf as f64;
            }
        }
        integral /= (n * n * W * H) as f64;
        assert!((integral - 1.0).abs() < 1e-5, "∫ pdf = {integral}");
        assert_eq!(d.pdf(Vec2::new(1.5, 0.5)), 0.0);
        assert_eq!(d.pdf(Vec2::new(0.5, -0.1)), 0.0);
    }

    /// `sample_lanes` and `pdf_lanes` are `sample` and `pdf` lane by lane,
    /// bit for bit, at every lane width built: random numbers, the corners,
    /// numbers on and beside the alias buckets' edges, points outside and NaN.
    #[test]
    fn lanes_are_scalar_bitwise() {
        use crate::simd::check::{each_simd, Visit};
        struct V(Vec<(Distribution2D, Vec<Vec2>)>);
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                for (d, us) in &self.0 {
                    for c in us.chunks(F::WIDTH).filter(|c| c.len() == F::WIDTH) {
                        let (x, y) = (gather::<F>(|l| c[l].x), gather::<F>(|l| c[l].y));
                        let (px, py, pdf) = d.sample_lanes(x, y);
                        let (px, py, pdf) = (px.to_array(), py.to_array(), pdf.to_array());
                        let lane_pdf = d.pdf_lanes(x, y).to_array();
                        for (l, u) in c.iter().enumerate() {
                            let (p, want) = d.sample(*u);
                            let got = (px.as_ref()[l], py.as_ref()[l], pdf.as_ref()[l]);
                            assert_eq!(
                                (got.0.to_bits(), got.1.to_bits(), got.2.to_bits()),
                                (p.x.to_bits(), p.y.to_bits(), want.to_bits()),
                                "{} sample at {u}",
                                F::NAME
                            );
                            let want = d.pdf(*u);
                            assert_eq!(lane_pdf.as_ref()[l].to_bits(), want.to_bits(), "{} pdf at {u}", F::NAME);
                        }
                    }
                }
            }
        }
        let mut us: Vec<Vec2> = (0..4096).map(|i| random_u(5, i)).collect();
        for n in [W, H, 7] {
            for k in 0..=n {
                let e = k as f32 / n as f32;
                for x in [e, f32::from_bits(e.to_bits().saturating_sub(1)), f32::from_bits(e.to_bits() + 1)] {
                    us.push(Vec2::new(x.min(1.0 - f32::EPSILON / 2.0), 0.37));
                    us.push(Vec2::new(0.61, x.min(1.0 - f32::EPSILON / 2.0)));
                }
            }
        }
        us.extend([Vec2::ZERO, Vec2::new(1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0), Vec2::new(1.0, 1.0)]);
        us.extend([Vec2::new(-0.5, 0.5), Vec2::new(0.5, 1.5), Vec2::new(f32::NAN, 0.5)]);
        while us.len() % 16 != 0 {
            us.push(Vec2::new(0.3, 0.7));
        }
        // The sample side takes numbers in [0, 1): the points outside only go to pdf.
        let inside: Vec<Vec2> = us
            .iter()
            .map(|u| if (0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y) { *u } else { Vec2::ZERO })
            .collect();
        let skewed: Vec<f32> =
            (0..37 * 11).map(|k| ((k * 7919) % 101) as f32 * if k % 5 == 0 { 0.0 } else { 1.0 }).collect();
        let mut v = V(vec![
            (Distribution2D::new(&WEIGHTS, W, H).unwrap(), inside.clone()),
            (Distribution2D::new(&skewed, 37, 11).unwrap(), inside),
        ]);
        v.visit::<f32>();
        each_simd(&mut v);
        // pdf alone over points outside and NaN.
        struct P(Distribution2D, Vec<Vec2>);
        impl Visit for P {
            fn visit<F: Float>(&mut self) {
                for c in self.1.chunks(F::WIDTH).filter(|c| c.len() == F::WIDTH) {
                    let got = self.0.pdf_lanes(gather::<F>(|l| c[l].x), gather::<F>(|l| c[l].y)).to_array();
                    for (l, u) in c.iter().enumerate() {
                        assert_eq!(got.as_ref()[l].to_bits(), self.0.pdf(*u).to_bits(), "{} pdf at {u}", F::NAME);
                    }
                }
            }
        }
        let mut p = P(Distribution2D::new(&WEIGHTS, W, H).unwrap(), us);
        p.visit::<f32>();
        each_simd(&mut p);
    }

    #[test]
    fn samples_carry_their_pdf_and_avoid_empty_cells() {
        let d = Distribution2D::new(&WEIGHTS, W, H).unwrap();
        // Includes the corners of the unit square of random numbers.
        let us = (0..20_000).map(|i| random_u(7, i)).chain([Vec2::ZERO, Vec2::ONE, Vec2::new(1.0 - f32::EPSILON, 0.0)]);
        for u in us {
            let (p, pdf) = d.sample(u);
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y), "{p}");
            assert!(pdf > 0.0);
            assert_eq!(pdf, d.pdf(p), "u = {u}, p = {p}");
            let (col, row) = ((p.x * W as f32) as usize, (p.y * H as f32) as usize);
            assert!(row != 1 && col != 3, "sampled an empty cell ({row}, {col})");
        }
    }

    #[test]
    fn cell_frequencies_pass_chi_square() {
        let d = Distribution2D::new(&WEIGHTS, W, H).unwrap();
        let total: f64 = WEIGHTS.iter().map(|&w| w as f64).sum();
        let n = 200_000;
        // Histogram on a grid twice as fine as the cells: also checks uniformity within a cell.
        let (gw, gh) = (2 * W, 2 * H);
        let mut observed = vec![0f64; gw * gh];
        for i in 0..n {
            let (p, _) = d.sample(random_u(11, i));
            observed[(p.y * gh as f32) as usize * gw + (p.x * gw as f32) as usize] += 1.0;
        }
        let (mut chi2, mut dof) = (0.0, 0);
        for (k, &o) in observed.iter().enumerate() {
            let expected = n as f64 * WEIGHTS[(k / gw / 2) * W + (k % gw) / 2] as f64 / total / 4.0;
            if expected == 0.0 {
                assert_eq!(o, 0.0, "samples in an empty cell");
                continue;
            }
            chi2 += (o - expected).powi(2) / expected;
            dof += 1;
        }
        let p = 1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(chi2);
        eprintln!("distribution2d chi-square: p = {p}");
        assert!(p > crate::testing::chi2::alpha(1), "p = {p}");
    }

    #[test]
    fn rejects_degenerate_grids() {
        assert!(Distribution2D::new(&[0.0; 6], 3, 2).is_none());
        assert!(Distribution2D::new(&[1.0, -1.0, 0.5, 0.5], 2, 2).is_none());
        assert!(Distribution2D::new(&[1.0, f32::INFINITY, 0.5, 0.5], 2, 2).is_none());
        assert!(Distribution2D::new(&[1.0; 5], 3, 2).is_none());
        assert!(Distribution2D::new(&[], 0, 0).is_none());
    }

    #[test]
    fn point_in_cell_stays_in_its_cell() {
        for n in [1usize, 3, 7, 1000, 4097] {
            for i in [0, n / 2, n - 1] {
                for t in [0.0, 0.5, 1.0 - f32::EPSILON / 2.0] {
                    let x = point_in_cell(i, t, n);
                    assert!(x < 1.0 && ((x * n as f32) as usize) == i, "n {n} i {i} t {t}: {x}");
                }
            }
        }
    }
}
