//! Weighted reservoir sampling with one random number: picks one of a
//! stream of candidates with probability proportional to its weight, in
//! one pass, keeping only the pick and the weights' sum (the selection
//! step of resampled importance sampling, Talbot et al. 2005).
//!
//! ```
//! use penumbra_render::sampling::reservoir::Reservoir;
//! let mut r = Reservoir::new(0.6);
//! for (item, w) in [('a', 1.0), ('b', 0.0), ('c', 3.0)] {
//!     r.add(item, w);
//! }
//! // 'c' holds the top three quarters of [0, 1).
//! assert_eq!(r.picked(), Some(('c', 3.0)));
//! assert_eq!(r.weight_sum(), 4.0);
//! ```

/// The largest f32 below 1: rescaling keeps the number in [0, 1).
pub(crate) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// One pick among weighted candidates, made with one uniform number.
#[derive(Debug, Clone, Copy)]
pub struct Reservoir<T> {
    /// The uniform number, rescaled after each decision to the branch
    /// taken, so that it stays uniform in [0, 1) given the decisions made.
    u: f32,
    picked: Option<(T, f32)>,
    sum: f32,
}

impl<T: Copy> Reservoir<T> {
    /// An empty reservoir that will decide with `u` in [0, 1).
    #[inline]
    pub fn new(u: f32) -> Self {
        Reservoir { u, picked: None, sum: 0.0 }
    }

    /// Offers `item` with weight `w`: it replaces the pick with probability
    /// w / (the sum of the weights so far), so after the last candidate
    /// each is the pick with probability w_i / Σ w. Weights that are not
    /// positive and finite are skipped.
    #[inline]
    pub fn add(&mut self, item: T, w: f32) {
        if !(w > 0.0 && w.is_finite()) {
            return;
        }
        self.sum += w;
        let q = w / self.sum;
        if self.u < q {
            self.u /= q;
            self.picked = Some((item, w));
        } else {
            self.u = (self.u - q) / (1.0 - q);
        }
        self.u = self.u.min(ONE_MINUS_EPSILON);
    }

    /// The pick and its weight (`None` when no weight was positive).
    #[inline]
    pub fn picked(&self) -> Option<(T, f32)> {
        self.picked
    }

    /// The sum of the weights offered.
    #[inline]
    pub fn weight_sum(&self) -> f32 {
        self.sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With u on a grid of n points the picks' counts are n w_i / Σ w, up
    /// to the rounding of the grid: the reservoir is an inverse-CDF pick
    /// whose intervals are reordered, not a biased one.
    #[test]
    fn picks_in_proportion_to_the_weights() {
        let weights = [0.5, 0.0, 3.0, 1e-3, 2.25, f32::NAN, 7.0, 0.125];
        let sum: f32 = weights.iter().filter(|w| w.is_finite()).sum();
        let n = 1 << 20;
        let mut counts = [0u32; 8];
        for k in 0..n {
            let mut r = Reservoir::new((k as f32 + 0.5) / n as f32);
            for (i, &w) in weights.iter().enumerate() {
                r.add(i, w);
            }
            assert_eq!(r.weight_sum(), sum);
            let (i, w) = r.picked().unwrap();
            assert_eq!(w, weights[i]);
            counts[i] += 1;
        }
        for (i, &w) in weights.iter().enumerate() {
            let expected = if w.is_finite() { n as f64 * (w / sum) as f64 } else { 0.0 };
            // Each decision's rescaling loses at most a few ulps of u: a
            // few grid points per boundary.
            assert!(
                (counts[i] as f64 - expected).abs() <= 16.0,
                "candidate {i}: {} picks, expected {expected:.1}",
                counts[i]
            );
        }
    }

    #[test]
    fn nothing_positive_picks_nothing() {
        let mut r = Reservoir::new(0.3);
        r.add(1, 0.0);
        r.add(2, -1.0);
        r.add(3, f32::INFINITY);
        assert!(r.picked().is_none());
        assert_eq!(r.weight_sum(), 0.0);
    }
}
