//! [`V3`]: three-component vectors whose components are lanes, with glam's
//! `Vec3` arithmetic in glam's order of operations, so that lane `l` of a
//! result is bitwise what glam computes for lane `l`'s inputs.
//!
//! glam's scalar `Vec3` (not `Vec3A`) does each component with plain `f32`
//! operations: a dot product is `(x·x' + y·y') + z·z'`, a length the square
//! root of that, `normalize` a multiplication by `1 / length`, a division by a
//! scalar three divisions, and `max_element` `max(max(x, y), z)` with
//! `a > b ? a : b`, which is [`Float::max`]'s `maxps` rule.

use super::Float;
use glam::Vec3;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A `Vec3` per lane.
#[derive(Debug, Clone, Copy)]
pub struct V3<F> {
    /// The lanes' x components.
    pub x: F,
    /// The lanes' y components.
    pub y: F,
    /// The lanes' z components.
    pub z: F,
}

impl<F: Float> V3<F> {
    /// Lanes from their components.
    #[inline(always)]
    pub fn new(x: F, y: F, z: F) -> Self {
        V3 { x, y, z }
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        V3 { x: F::splat(v.x), y: F::splat(v.y), z: F::splat(v.z) }
    }

    /// Lane `l` = `f(l)`.
    #[inline(always)]
    pub fn gather(f: impl Fn(usize) -> Vec3) -> Self {
        V3 { x: super::gather(|l| f(l).x), y: super::gather(|l| f(l).y), z: super::gather(|l| f(l).z) }
    }

    /// Each lane's vector.
    #[inline(always)]
    pub fn to_lanes(self) -> [Vec3; 16] {
        let (x, y, z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
        let mut out = [Vec3::ZERO; 16];
        for (l, v) in out.iter_mut().enumerate().take(F::WIDTH) {
            *v = Vec3::new(x.as_ref()[l], y.as_ref()[l], z.as_ref()[l]);
        }
        out
    }

    /// glam's `dot`.
    #[inline(always)]
    pub fn dot(self, o: Self) -> F {
        (self.x * o.x + self.y * o.y) + self.z * o.z
    }

    /// glam's `cross`.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    /// glam's `length`.
    #[inline(always)]
    pub fn length(self) -> F {
        self.dot(self).sqrt()
    }

    /// glam's `normalize`: `self * (1 / length)`.
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (F::splat(1.0) / self.length())
    }

    /// glam's `abs`.
    #[inline(always)]
    pub fn abs(self) -> Self {
        V3 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// glam's `max_element`.
    #[inline(always)]
    pub fn max_element(self) -> F {
        self.x.max(self.y).max(self.z)
    }

    /// Component-wise product (glam's `Vec3 * Vec3`).
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        V3 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }

    /// Lane by lane, `t` where `m` holds, else `f`.
    #[inline(always)]
    pub fn select(m: F::Mask, t: Self, f: Self) -> Self {
        V3 { x: F::select(m, t.x, f.x), y: F::select(m, t.y, f.y), z: F::select(m, t.z, f.z) }
    }

    /// Lanes where some component is not zero (glam's `v != Vec3::ZERO`).
    #[inline(always)]
    pub fn ne_zero(self) -> F::Mask {
        let z = F::splat(0.0);
        self.x.cmp_ne(z) | self.y.cmp_ne(z) | self.z.cmp_ne(z)
    }
}

impl<F: Float> Add for V3<F> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl<F: Float> Sub for V3<F> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl<F: Float> Neg for V3<F> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// Every component divided by the lane's scalar (glam's `Vec3 / f32`).
impl<F: Float> Div<F> for V3<F> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: F) -> Self {
        V3 { x: self.x / s, y: self.y / s, z: self.z / s }
    }
}

/// Every component times the lane's scalar (glam's `Vec3 * f32` and `f32 * Vec3`).
impl<F: Float> Mul<F> for V3<F> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: F) -> Self {
        V3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::check::{each_simd, same, Visit};
    use crate::simd::Mask;

    /// Every operation, lane by lane, bitwise glam's on random vectors
    /// (with zeros, negative zeros and huge components among them).
    struct GlamCheck;

    impl Visit for GlamCheck {
        fn visit<F: Float>(&mut self) {
            let mut state = 0x2545f4914f6cdd1du64;
            let mut next = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                match state % 11 {
                    0 => 0.0,
                    1 => -0.0,
                    2 => 3e37 * if state & 64 == 0 { 1.0 } else { -1.0 },
                    _ => (state >> 40) as f32 / (1u64 << 23) as f32 - 1.0,
                }
            };
            let same_v = |x: Vec3, y: Vec3| same(x.x, y.x, true) && same(x.y, y.y, true) && same(x.z, y.z, true);
            for _ in 0..500 {
                let a: Vec<Vec3> = (0..F::WIDTH).map(|_| Vec3::new(next(), next(), next())).collect();
                let b: Vec<Vec3> = (0..F::WIDTH).map(|_| Vec3::new(next(), next(), next())).collect();
                let s: Vec<f32> = (0..F::WIDTH).map(|_| next()).collect();
                let (va, vb) = (V3::<F>::gather(|l| a[l]), V3::<F>::gather(|l| b[l]));
                let vs: F = crate::simd::gather(|l| s[l]);
                let (add, sub, neg, cross) =
                    ((va + vb).to_lanes(), (va - vb).to_lanes(), (-va).to_lanes(), va.cross(vb).to_lanes());
                let (norm, abs, mul) = (va.normalize().to_lanes(), va.abs().to_lanes(), (va * vs).to_lanes());
                let (div, elem) = ((va / vs).to_lanes(), va.mul_elem(vb).to_lanes());
                let (dot, len, maxe) = (va.dot(vb).to_array(), va.length().to_array(), va.max_element().to_array());
                let ne = va.ne_zero().bitmask();
                for l in 0..F::WIDTH {
                    let (p, q, k) = (a[l], b[l], s[l]);
                    assert!(same_v(add[l], p + q) && same_v(sub[l], p - q) && same_v(neg[l], -p), "{}", F::NAME);
                    assert!(same_v(cross[l], p.cross(q)), "{p} x {q} on {}", F::NAME);
                    let n = p * p.length_recip();
                    assert!(same_v(norm[l], n), "normalize {p} on {}: {} against {n}", F::NAME, norm[l]);
                    assert!(same_v(abs[l], p.abs()) && same_v(mul[l], p * k) && same_v(mul[l], k * p), "{}", F::NAME);
                    assert!(same_v(div[l], p / k) && same_v(elem[l], p * q), "{}", F::NAME);
                    assert!(same(dot.as_ref()[l], p.dot(q), true) && same(len.as_ref()[l], p.length(), true));
                    assert!(same(maxe.as_ref()[l], p.max_element(), true), "max_element {p} on {}", F::NAME);
                    assert_eq!(ne >> l & 1 != 0, p != Vec3::ZERO, "{p} on {}", F::NAME);
                }
            }
        }
    }

    #[test]
    fn lanes_are_glam_bitwise() {
        GlamCheck.visit::<f32>();
        let names = each_simd(&mut GlamCheck);
        eprintln!("checked f32 and {names:?}");
    }
}
