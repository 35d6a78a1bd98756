//! Inverse trigonometric functions for the hot paths (environment-map and
//! sphere parameterisations), faster than libm's and accurate to a few
//! units in the last place: Cephes' single-precision `atanf` (range reduced
//! to |x| ≤ tan(π/8), then an odd polynomial of degree 9).

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// arctan(x).
#[inline]
pub fn atan(x: f32) -> f32 {
    let a = x.abs();
    // tan(3π/8) and tan(π/8).
    let (base, t) = if a > 2.414_213_6 {
        (FRAC_PI_2, -1.0 / a)
    } else if a > 0.414_213_57 {
        (FRAC_PI_4, (a - 1.0) / (a + 1.0))
    } else {
        (0.0, a)
    };
    let z = t * t;
    let p = (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t + t;
    (base + p).copysign(x)
}

/// atan2(y, x) in [-π, π], with the quadrant conventions of `f32::atan2`
/// for finite non-zero arguments (and 0 for (0, 0)).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    if x == 0.0 {
        return if y == 0.0 { 0.0 } else { FRAC_PI_2.copysign(y) };
    }
    let r = atan(y / x);
    if x > 0.0 {
        r
    } else {
        r + PI.copysign(y)
    }
}

/// arccos(x) for x in [-1, 1] (clamped).
#[inline]
pub fn acos(x: f32) -> f32 {
    let x = x.clamp(-1.0, 1.0);
    let s = ((1.0 - x) * (1.0 + x)).sqrt();
    let r = atan(s / x.abs());
    if x >= 0.0 {
        r
    } else {
        PI - r
    }
}

/// ⌊x⌋ as an index for x in [0, 2³¹); 0 for negative x and NaN, i32::MAX
/// above. `x as usize` is exact for more values but costs about twice the
/// instructions (a 64-bit unsigned saturating conversion); every caller
/// clamps to a table's size anyway.
#[inline(always)]
pub fn index(x: f32) -> usize {
    (x as i32).max(0) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against f64 references over a dense sweep: within 4e-7 absolute.
    #[test]
    fn agree_with_f64() {
        let mut worst = [0.0f64; 3];
        for i in 0..=200_000 {
            let x = -50.0 + 100.0 * i as f32 / 200_000.0;
            worst[0] = worst[0].max((atan(x) as f64 - (x as f64).atan()).abs());
            let c = -1.0 + 2.0 * i as f32 / 200_000.0;
            worst[1] = worst[1].max((acos(c) as f64 - (c as f64).acos()).abs());
            let phi = -3.2 + 6.4 * i as f64 / 200_000.0;
            for r in [1e-3f64, 1.0, 7.0] {
                let (y, x) = ((phi.sin() * r) as f32, (phi.cos() * r) as f32);
                worst[2] = worst[2].max((atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs());
            }
        }
        assert!(worst.iter().all(|&w| w < 4e-7), "{worst:?}");
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, 0.0), -FRAC_PI_2);
        assert!((atan2(0.0, -1.0) - PI).abs() < 1e-7);
        assert_eq!(acos(1.0), 0.0);
        assert!((acos(-1.0) - PI).abs() < 1e-7);
    }
}
