//! Russian roulette driven by what a path is expected to bring (after
//! Vorba and Křivánek, "Adjoint-Driven Russian Roulette and Splitting in
//! Light Transport Simulation", SIGGRAPH 2016), with the estimates a path
//! guide already has.
//!
//! A path with throughput β about to follow direction ω from x is expected
//! to add β · L_i(x, ω) to its pixel, whose value is I. Roulette by
//! throughput alone (Mitsuba's, `Termination::survive`) kills paths that
//! the guide has just sent towards the light: a guided direction has a
//! large density and hence a small β. Here a path survives with the
//! probability q = max(min(r, 1), q_β), where r = β̄ · L̂_i(x, ω) / Î is
//! its expected share of the pixel and q_β = min(max(β) η², 0.95) the
//! throughput roulette's: a path the guide expects to matter goes on, and
//! none is killed more often than throughput roulette would kill it, so
//! β / q stays below 1 / η² as there (no weight grows from a bad estimate).
//! It plays at every bounce where the guide knows L̂_i, the others keep
//! throughput roulette from `rr_depth` on. L̂_i comes from the spatial
//! leaf's quadtree ([`DTree::radiance`]), Î from the image of the last
//! training pass ([`PixelEstimate`]). Any q > 0 keeps the estimate unbiased
//! (β is divided by it); the estimates only decide where time goes. There
//! is no splitting: a stream slot holds one path.
//!
//! Measured on `scenes/door-ajar.xml` (guided, 256 spp, 2 threads): relMSE
//! 2.28e-3 in 5.5 s with throughput roulette, 1.47e-3 in 4.96 s with this
//! rule. Tried: the paper's window (q = r below r = 1/3, else 1) without
//! the throughput term, whose survivors' weights grew to 20x: even on that
//! scene, worse on the Cornell box; survival min(3r, 1) or min(10r, 1), or
//! only from depth 3 or 5: between the two.
//!
//! [`DTree::radiance`]: super::dtree::DTree::radiance

use super::dtree::Bytes;

/// The survival probability of a path expected to bring `r` times its
/// pixel's value (`r` ≥ 0) whose throughput roulette would let it survive
/// with probability `q_beta`: max(min(r, 1), q_beta).
#[inline]
pub fn survival(r: f32, q_beta: f32) -> f32 {
    r.min(1.0).max(q_beta)
}

/// The image as far as a training pass saw it: per pixel of the film (a
/// crop window's when there is one), the channel mean of its value.
/// Pixels darker than [`PixelEstimate::FLOOR`] of the mean count as that
/// (their few samples say little, and a path there would otherwise never
/// play roulette). Blurring it over 9x9 pixels changed nothing measurable.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelEstimate {
    /// The film's first pixel in full-image coordinates.
    offset: (u32, u32),
    width: u32,
    height: u32,
    values: Vec<f32>,
}

impl PixelEstimate {
    /// The share of the image's mean below which a pixel counts as that.
    pub const FLOOR: f32 = 0.05;

    /// The estimate from a film of `width` x `height` pixels at `offset`
    /// (full-image coordinates) whose pixels have the channel means
    /// `values` (row-major); `None` when the image is black or its size
    /// does not match.
    pub fn new(offset: (u32, u32), width: u32, height: u32, values: Vec<f32>) -> Option<PixelEstimate> {
        if values.len() != width as usize * height as usize || values.is_empty() {
            return None;
        }
        let finite = values.iter().filter(|v| v.is_finite() && **v > 0.0);
        let mean = finite.map(|&v| v as f64).sum::<f64>() / values.len() as f64;
        let floor = (mean as f32) * Self::FLOOR;
        if !(floor > 0.0 && floor.is_finite()) {
            return None;
        }
        let values = values.into_iter().map(|v| if v.is_finite() && v > floor { v } else { floor }).collect();
        Some(PixelEstimate { offset, width, height, values })
    }

    /// The value of pixel `global` (full-image coordinates; pixels outside
    /// the film, in a crop's ring, take the nearest film pixel's).
    #[inline]
    pub fn at(&self, global: (u32, u32)) -> f32 {
        let x = global.0.saturating_sub(self.offset.0).min(self.width - 1);
        let y = global.1.saturating_sub(self.offset.1).min(self.height - 1);
        self.values[(y * self.width + x) as usize]
    }

    /// Appends it to a checkpoint's bytes.
    pub fn encode(&self, out: &mut Vec<u8>) {
        for v in [self.offset.0, self.offset.1, self.width, self.height] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in &self.values {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }

    pub(crate) fn decode(r: &mut Bytes) -> Result<PixelEstimate, String> {
        let offset = (r.u32()?, r.u32()?);
        let (width, height) = (r.u32()?, r.u32()?);
        let n = width as u64 * height as u64;
        if n == 0 || n > (r.b.len() - r.at.min(r.b.len())) as u64 / 4 {
            return Err(format!("a pixel estimate of {width}x{height} pixels"));
        }
        let mut values = Vec::with_capacity(n as usize);
        for _ in 0..n {
            let v = r.f32()?;
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("a pixel estimate of {v}"));
            }
            values.push(v);
        }
        Ok(PixelEstimate { offset, width, height, values })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn survival_keeps_what_is_expected_to_matter_and_what_throughput_would_keep() {
        assert_eq!(survival(0.5, 0.1), 0.5);
        assert_eq!(survival(3.0, 0.1), 1.0, "expected to bring more than its pixel");
        assert_eq!(survival(0.01, 0.3), 0.3, "never below throughput roulette's");
        assert_eq!(survival(0.0, 0.95), 0.95);
        assert_eq!(survival(1e30, 0.0), 1.0);
    }

    #[test]
    fn pixels_are_floored_and_looked_up_in_film_coordinates() {
        // A 3x2 crop at (10, 20); the mean is (0 + 1 + 2 + 3 + 4 + 50) / 6 = 10.
        let e = PixelEstimate::new((10, 20), 3, 2, vec![0.0, 1.0, 2.0, 3.0, 4.0, 50.0]).unwrap();
        assert_eq!(e.at((10, 20)), 0.5, "a black pixel counts as 5 % of the mean");
        assert_eq!(e.at((11, 20)), 1.0);
        assert_eq!(e.at((12, 21)), 50.0);
        // The ring around the crop takes the nearest pixel's value.
        assert_eq!(e.at((0, 0)), 0.5);
        assert_eq!(e.at((99, 99)), 50.0);
        assert_eq!(e.at((13, 20)), 2.0);
        assert!(PixelEstimate::new((0, 0), 2, 1, vec![0.0, 0.0]).is_none(), "a black image");
        assert!(PixelEstimate::new((0, 0), 2, 2, vec![1.0; 3]).is_none(), "a size mismatch");
        assert!(PixelEstimate::new((0, 0), 1, 1, vec![f32::NAN]).is_none());
    }

    #[test]
    fn encodes_and_decodes() {
        let e = PixelEstimate::new((1, 2), 2, 2, vec![1.0, 2.0, 0.0, 7.0]).unwrap();
        let mut out = Vec::new();
        e.encode(&mut out);
        let mut r = Bytes { b: &out, at: 0 };
        assert_eq!(PixelEstimate::decode(&mut r).unwrap(), e);
        assert_eq!(r.at, out.len());
        // A size that the bytes cannot hold is an error, not an allocation.
        let mut huge = out.clone();
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(PixelEstimate::decode(&mut Bytes { b: &huge, at: 0 }).is_err());
        let mut bad = out.clone();
        bad[16..20].copy_from_slice(&(-1.0f32).to_le_bytes());
        assert!(PixelEstimate::decode(&mut Bytes { b: &bad, at: 0 }).is_err());
    }
}
