//! Piecewise-constant 1D distribution over [0, 1) or over n discrete items.

/// A discrete / piecewise-constant distribution built from non-negative weights.
#[derive(Debug, Clone)]
pub struct Distribution1D {
    /// Unnormalised weights.
    pub func: Vec<f32>,
    /// Normalised CDF with `func.len() + 1` entries, cdf[0] = 0, cdf[n] = 1.
    pub cdf: Vec<f32>,
    /// Sum of the weights.
    pub total: f64,
}

impl Distribution1D {
    /// Returns `None` when no weight is positive (or a weight is not finite).
    pub fn new(weights: &[f32]) -> Option<Distribution1D> {
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &w in weights {
            acc += w as f64;
            cdf.push(acc as f32);
        }
        if acc <= 0.0 {
            return None;
        }
        for c in &mut cdf {
            *c = (*c as f64 / acc) as f32;
        }
        *cdf.last_mut().unwrap() = 1.0;
        Some(Distribution1D { func: weights.to_vec(), cdf, total: acc })
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Picks an item with probability proportional to its weight. Returns
    /// the item, its probability and `u` remapped to [0, 1) within the item,
    /// so the same number can be reused for a further choice.
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        // First index whose upper CDF bound exceeds u.
        let i = self.cdf[1..].partition_point(|&c| c <= u).min(self.len() - 1);
        let i = self.skip_empty(i);
        let pmf = self.pmf(i);
        let u_re = ((u - self.cdf[i]) / pmf).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        (i, pmf, u_re)
    }

    /// Rounding can land on a zero-probability item; move to a valid one.
    fn skip_empty(&self, mut i: usize) -> usize {
        while self.pmf(i) <= 0.0 && i > 0 {
            i -= 1;
        }
        while self.pmf(i) <= 0.0 && i + 1 < self.len() {
            i += 1;
        }
        i
    }
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
}
