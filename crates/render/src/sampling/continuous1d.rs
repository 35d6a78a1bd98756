//! Mitsuba 3.9.1's `ContinuousDistribution` (include/mitsuba/core/distr_1d.h):
//! a density on an interval given by regularly spaced values and linear
//! in between, sampled exactly by inverting its piecewise-quadratic CDF.
//! `tabphase` tabulates its phase function with it.

/// A piecewise-linear density over `range`, from `n ≥ 2` values at
/// regularly spaced points (the first at `range.0`, the last at `range.1`).
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousDistribution {
    range: (f32, f32),
    /// The values as given (unnormalised).
    pdf: Vec<f32>,
    /// cdf[i]: the integral up to the end of interval i (unnormalised).
    cdf: Vec<f32>,
    /// First and last interval with mass.
    valid: (usize, usize),
    integral: f32,
    normalization: f32,
    interval: f32,
    inv_interval: f32,
}

impl ContinuousDistribution {
    /// Builds the distribution; the error says what is wrong with the
    /// values (fewer than two, negative or not finite, or all zero), as
    /// Mitsuba's constructor refuses them.
    pub fn new(range: (f32, f32), values: &[f32]) -> Result<ContinuousDistribution, String> {
        if values.len() < 2 {
            return Err(format!("{} value(s): a tabulated density needs at least two", values.len()));
        }
        if range.0.partial_cmp(&range.1) != Some(std::cmp::Ordering::Less) {
            return Err(format!("the range [{}, {}] is empty", range.0, range.1));
        }
        if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
            return Err(format!("value {i} ({v}) must be finite and not negative"));
        }
        // As compute_cdf_scalar: the running integral in f64, trapezoids.
        let interval = (range.1 as f64 - range.0 as f64) / (values.len() - 1) as f64;
        let mut integral = 0.0f64;
        let mut valid: Option<(usize, usize)> = None;
        let mut cdf = Vec::with_capacity(values.len() - 1);
        for i in 0..values.len() - 1 {
            let value = 0.5 * interval * (values[i] as f64 + values[i + 1] as f64);
            integral += value;
            cdf.push(integral as f32);
            if value > 0.0 {
                valid = Some((valid.map_or(i, |v| v.0), i));
            }
        }
        let Some(valid) = valid else {
            return Err("every value is zero: the density has no mass".to_string());
        };
        let integral = cdf[valid.1];
        Ok(ContinuousDistribution {
            range,
            pdf: values.to_vec(),
            cdf,
            valid,
            integral,
            normalization: 1.0 / integral,
            interval: interval as f32,
            inv_interval: 1.0 / interval as f32,
        })
    }

    /// The normalised density at `x` (0 outside the range).
    pub fn eval_pdf_normalized(&self, x: f32) -> f32 {
        if !(x >= self.range.0 && x <= self.range.1) {
            return 0.0;
        }
        let x = (x - self.range.0) * self.inv_interval;
        let i = (x as usize).min(self.pdf.len() - 2);
        let w1 = x - i as f32;
        let w0 = 1.0 - w1;
        w0.mul_add(self.pdf[i], w1 * self.pdf[i + 1]) * self.normalization
    }

    /// Maps a uniform `u` in [0, 1) to the distribution: the interval by
    /// binary search in the CDF, then the root of the linear density's
    /// quadratic CDF inside it.
    pub fn sample(&self, u: f32) -> f32 {
        let u = u * self.integral;
        // The first interval in [valid.0, valid.1] whose CDF reaches u.
        let (lo, hi) = self.valid;
        let i = lo + self.cdf[lo..hi].partition_point(|&c| c < u);
        let (y0, y1) = (self.pdf[i], self.pdf[i + 1]);
        let c0 = if i > 0 { self.cdf[i - 1] } else { 0.0 };
        let s = (u - c0) * self.inv_interval;
        let t = if y0 == y1 {
            s / y0
        } else {
            (y0 - crate::math::safe_sqrt(y0.mul_add(y0, 2.0 * s * (y1 - y0)))) / (y0 - y1)
        };
        (i as f32 + t).mul_add(self.interval, self.range.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use statrs::distribution::{ChiSquared, ContinuousCDF};

    /// Samples follow the normalised density (chi-square over 64 bins,
    /// expected counts by a fine midpoint rule), and a density with one
    /// value changed is rejected.
    #[test]
    fn samples_follow_the_density_chi2() {
        let values = [0.0, 0.5, 2.0, 2.0, 0.1, 0.0, 0.0, 1.0, 3.0];
        let d = ContinuousDistribution::new((-1.0, 1.0), &values).unwrap();
        let mut wrong = values;
        wrong[4] = 0.3;
        let w = ContinuousDistribution::new((-1.0, 1.0), &wrong).unwrap();
        let (bins, n) = (64usize, 200_000usize);
        let mut observed = vec![0f64; bins];
        for k in 0..n {
            let u = crate::sampling::rng::to_unit_f32(crate::sampling::rng::hash_words(&[11, k as u64]));
            let x = d.sample(u);
            assert!((-1.0..=1.0).contains(&x), "sample {x} outside the range");
            observed[(((x + 1.0) * 0.5 * bins as f32) as usize).min(bins - 1)] += 1.0;
        }
        let p_value = |dist: &ContinuousDistribution| {
            let (mut chi2, mut dof) = (0.0, 0usize);
            for (b, &o) in observed.iter().enumerate() {
                let sub = 64;
                let e: f64 = (0..sub)
                    .map(|s| {
                        let x = -1.0 + 2.0 * (b as f64 + (s as f64 + 0.5) / sub as f64) / bins as f64;
                        dist.eval_pdf_normalized(x as f32) as f64
                    })
                    .sum::<f64>()
                    / sub as f64
                    * (2.0 / bins as f64)
                    * n as f64;
                if e > 5.0 {
                    chi2 += (o - e) * (o - e) / e;
                    dof += 1;
                } else {
                    assert!(o < 20.0, "bin {b}: {o} samples where {e} are expected");
                }
            }
            1.0 - ChiSquared::new((dof - 1) as f64).unwrap().cdf(chi2)
        };
        let p = p_value(&d);
        println!("continuous1d chi2: p = {p:.4}");
        assert!(p > 0.005, "p = {p}");
        let pw = p_value(&w);
        assert!(pw < 0.005, "a changed value was not detected: p = {pw}");
    }

    /// The density integrates to 1 and interpolates the given values.
    #[test]
    fn normalised_and_linear() {
        let d = ContinuousDistribution::new((-1.0, 1.0), &[1.0, 3.0, 0.0]).unwrap();
        // ∫ = 0.5·(1+3)·1 + 0.5·(3+0)·1 = 3.5.
        assert!((d.eval_pdf_normalized(-1.0) - 1.0 / 3.5).abs() < 1e-6);
        assert!((d.eval_pdf_normalized(-0.5) - 2.0 / 3.5).abs() < 1e-6);
        assert!((d.eval_pdf_normalized(0.0) - 3.0 / 3.5).abs() < 1e-6);
        assert_eq!(d.eval_pdf_normalized(1.5), 0.0);
        let n = 100_000;
        let total: f64 = (0..n).map(|i| d.eval_pdf_normalized(-1.0 + 2.0 * (i as f32 + 0.5) / n as f32) as f64).sum();
        assert!((total * 2.0 / n as f64 - 1.0).abs() < 1e-4);
        // The inverse CDF: the median of a uniform density is its midpoint.
        let u = ContinuousDistribution::new((-1.0, 1.0), &[2.0, 2.0]).unwrap();
        assert!(u.sample(0.5).abs() < 1e-6);
    }

    #[test]
    fn bad_values_are_errors() {
        assert!(ContinuousDistribution::new((-1.0, 1.0), &[1.0]).unwrap_err().contains("at least two"));
        assert!(ContinuousDistribution::new((-1.0, 1.0), &[1.0, -1.0]).unwrap_err().contains("value 1"));
        assert!(ContinuousDistribution::new((-1.0, 1.0), &[0.0, 0.0]).unwrap_err().contains("no mass"));
        assert!(ContinuousDistribution::new((-1.0, 1.0), &[f32::NAN, 1.0]).unwrap_err().contains("value 0"));
    }
}
