//! The scalar instance: `f32` with `bool` masks and `i32` integers, one lane.
//! Each operation mirrors the vector instruction the SIMD instances use,
//! special cases included.

use super::{Float, Int, Mask};

impl Mask for bool {
    #[inline(always)]
    fn splat(b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self as u32
    }
}

impl Int for i32 {
    type Mask = bool;
    type Array = [i32; 1];

    #[inline(always)]
    fn splat(v: i32) -> i32 {
        v
    }
    #[inline(always)]
    fn from_array(a: [i32; 1]) -> i32 {
        a[0]
    }
    #[inline(always)]
    fn to_array(self) -> [i32; 1] {
        [self]
    }
    #[inline(always)]
    fn wrapping_add(self, o: i32) -> i32 {
        i32::wrapping_add(self, o)
    }
    #[inline(always)]
    fn wrapping_sub(self, o: i32) -> i32 {
        i32::wrapping_sub(self, o)
    }
    #[inline(always)]
    fn wrapping_mul(self, o: i32) -> i32 {
        i32::wrapping_mul(self, o)
    }
    #[inline(always)]
    fn shift_left(self, n: u32) -> i32 {
        if n < 32 {
            self << n
        } else {
            0
        }
    }
    #[inline(always)]
    fn shift_right(self, n: u32) -> i32 {
        self >> n.min(31)
    }
    #[inline(always)]
    fn shift_right_logical(self, n: u32) -> i32 {
        if n < 32 {
            ((self as u32) >> n) as i32
        } else {
            0
        }
    }
    #[inline(always)]
    fn cmp_eq(self, o: i32) -> bool {
        self == o
    }
    #[inline(always)]
    fn cmp_gt(self, o: i32) -> bool {
        self > o
    }
    #[inline(always)]
    fn cmp_lt(self, o: i32) -> bool {
        self < o
    }
    #[inline(always)]
    fn select(m: bool, t: i32, f: i32) -> i32 {
        if m {
            t
        } else {
            f
        }
    }
}

impl Float for f32 {
    const WIDTH: usize = 1;
    const NAME: &'static str = "f32";
    type Mask = bool;
    type Int = i32;
    type Array = [f32; 1];

    #[inline(always)]
    fn splat(v: f32) -> f32 {
        v
    }
    #[inline(always)]
    fn from_array(a: [f32; 1]) -> f32 {
        a[0]
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 1] {
        [self]
    }
    #[inline(always)]
    fn load(s: &[f32]) -> f32 {
        s[0]
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        out[0] = self;
    }
    #[inline(always)]
    fn mul_add(self, a: f32, b: f32) -> f32 {
        f32::mul_add(self, a, b)
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn min(self, o: f32) -> f32 {
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        f32::floor(self)
    }
    #[inline(always)]
    fn round_ties_even(self) -> f32 {
        f32::round_ties_even(self)
    }
    #[inline(always)]
    fn copysign(self, sign: f32) -> f32 {
        f32::copysign(self, sign)
    }
    #[inline(always)]
    fn mulsign(self, sign: f32) -> f32 {
        f32::from_bits(f32::to_bits(self) ^ (f32::to_bits(sign) & 0x8000_0000))
    }
    #[inline(always)]
    fn cmp_eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn cmp_ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn cmp_lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn cmp_le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn cmp_gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn cmp_ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
    #[inline(always)]
    fn select(m: bool, t: f32, f: f32) -> f32 {
        if m {
            t
        } else {
            f
        }
    }
    #[inline(always)]
    fn to_bits(self) -> i32 {
        f32::to_bits(self) as i32
    }
    #[inline(always)]
    fn from_bits(i: i32) -> f32 {
        f32::from_bits(i as u32)
    }
    #[inline(always)]
    fn to_int_trunc(self) -> i32 {
        // `as` saturates and maps NaN to 0; cvttps2dq gives i32::MIN for both.
        if (-2_147_483_648.0..2_147_483_648.0).contains(&self) {
            self as i32
        } else {
            i32::MIN
        }
    }
    #[inline(always)]
    fn from_int(i: i32) -> f32 {
        i as f32
    }
    #[inline(always)]
    fn gather_table(table: &[f32], i: i32) -> f32 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize, "a gather from {} floats", table.len());
        table[(i as u32).min(table.len() as u32 - 1) as usize]
    }
}
