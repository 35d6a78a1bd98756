//! Discrete distribution over n items (or piecewise-constant over [0, 1)),
//! sampled in O(1) with Walker's alias method (Vose's construction, "A
//! linear algorithm for generating random numbers with a given
//! distribution", 1991): one table lookup and one comparison instead of a
//! binary search over a CDF. Mesh emitters pick a triangle and the envmap a
//! row and a column with it on every light sample.

use crate::math::fast;

/// A discrete distribution built from non-negative weights.
#[derive(Debug, Clone)]
pub struct Distribution1D {
    /// Unnormalised weights.
    pub func: Vec<f32>,
    /// Sum of the weights.
    pub total: f64,
    /// Probability of each item (weight / total).
    pmf: Vec<f32>,
    /// Per bucket i of [i/n, (i+1)/n): the share of the bucket that keeps
    /// item i, and the item that takes the rest.
    alias: Vec<(f32, u32)>,
}

impl Distribution1D {
    /// Returns `None` when no weight is positive (or a weight is not finite).
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn new(weights: &[f32]) -> Option<Distribution1D> {
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if !(total > 0.0) {
            return None;
        }
        let n = weights.len();
        // Vose: weights scaled to mean 1; each under-full bucket is topped up
        // by an over-full item, which then joins the list it now belongs to.
        let mut scaled: Vec<f64> = weights.iter().map(|&w| w as f64 * n as f64 / total).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        let mut alias = vec![(1.0f32, 0u32); n];
        for (i, a) in alias.iter_mut().enumerate() {
            a.1 = i as u32;
        }
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            alias[s] = (scaled[s] as f32, l as u32);
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // Leftovers are full up to rounding; one of zero weight (rounding
        // emptied `large` first) must never be picked: give its bucket away.
        let positive = weights.iter().position(|&w| w > 0.0).unwrap() as u32;
        for i in small.into_iter().chain(large) {
            alias[i] = if weights[i] > 0.0 { (1.0, i as u32) } else { (0.0, positive) };
        }
        let pmf = weights.iter().map(|&w| (w as f64 / total) as f32).collect();
        Some(Distribution1D { func: weights.to_vec(), total, pmf, alias })
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// True when there are no items (never for a distribution [`Distribution1D::new`] built).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Picks an item with probability proportional to its weight. Returns
    /// the item, its probability and `u` remapped to [0, 1) within the
    /// choice made, so the same number can be reused for a further choice.
    #[inline(always)]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let (i, u_re) = alias_pick(u, self.alias.len(), |b| self.alias[b]);
        (i, self.pmf[i], u_re)
    }

    /// The alias table: per bucket, the share kept and the item taking the rest.
    pub(crate) fn alias(&self) -> &[(f32, u32)] {
        &self.alias
    }
}

/// The alias method's pick among `n` buckets with table `bucket`
/// ([`Distribution1D::alias`]): the item and `u` remapped to [0, 1) within it.
#[inline(always)]
pub(crate) fn alias_pick(u: f32, n: usize, bucket: impl Fn(usize) -> (f32, u32)) -> (usize, f32) {
    let x = u * n as f32;
    let b = fast::index(x).min(n - 1);
    let f = x - b as f32;
    let (keep, other) = bucket(b);
    let (i, u_re) = if f < keep { (b, f / keep) } else { (other as usize, (f - keep) / (1.0 - keep)) };
    (i, u_re.clamp(0.0, 1.0 - f32::EPSILON / 2.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_frequencies_match_the_pmf() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]).unwrap();
        assert_eq!(d.pmf(1), 0.0);
        let n = 80_000;
        let mut counts = [0usize; 4];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p, ur) = d.sample_discrete(u);
            assert!((0.0..1.0).contains(&ur));
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        for (i, &c) in counts.iter().enumerate() {
            assert!((c as f32 / n as f32 - d.pmf(i)).abs() < 1e-3);
        }
    }

    #[test]
    fn rejects_degenerate_weights() {
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[1.0, f32::NAN]).is_none());
        assert!(Distribution1D::new(&[]).is_none());
    }

    /// The remapped number is uniform within each item (so reusing it is
    /// unbiased): per item, its histogram over 8 bins is flat.
    #[test]
    fn remapped_numbers_are_uniform_per_item() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0, 0.5]).unwrap();
        let n = 160_000;
        let mut bins = [[0usize; 8]; 5];
        for k in 0..n {
            let (i, _, ur) = d.sample_discrete((k as f32 + 0.5) / n as f32);
            bins[i][(ur * 8.0) as usize] += 1;
        }
        for (i, b) in bins.iter().enumerate() {
            let expected = n as f32 * d.pmf(i) / 8.0;
            for &c in b {
                assert!((c as f32 - expected).abs() <= 2.0 + 1e-3 * expected, "item {i}: {b:?}");
            }
        }
    }

    /// Items of zero weight are never picked, even next to tiny weights
    /// where rounding leaves buckets over.
    #[test]
    fn zero_weights_are_never_picked() {
        let mut w = vec![0.0f32; 1000];
        for (i, x) in w.iter_mut().enumerate().step_by(7) {
            *x = 1e-3 + (i % 13) as f32;
        }
        let d = Distribution1D::new(&w).unwrap();
        for k in 0..100_000 {
            let (i, p, _) = d.sample_discrete(k as f32 / 100_000.0);
            assert!(w[i] > 0.0 && p > 0.0, "picked item {i} of weight 0");
        }
        let sum: f64 = (0..w.len()).map(|i| d.pmf(i) as f64).sum();
        assert!((sum - 1.0).abs() < 1e-5);
    }
}
