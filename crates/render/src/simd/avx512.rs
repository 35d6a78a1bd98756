//! Sixteen lanes in one AVX-512 register: [`F32x16`], [`I32x16`] and the
//! mask [`M32x16`] (one bit per lane, an AVX-512 mask register). Compiled
//! only where the target has AVX-512F; every intrinsic here is AVX-512F's
//! (float bit operations go through the integer ones, which need no DQ).

use super::{Float, Int, Mask};
use std::arch::x86_64::*;
use std::fmt;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

// SAFETY (every `unsafe` block in this file unless it says otherwise): the
// intrinsics called need only SSE2 or AVX-512F, which the `cfg` on this
// module guarantees at compile time, and touch no memory.

/// Sixteen f32 lanes in one AVX-512 register.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x16(__m512);

/// Sixteen i32 lanes in one AVX-512 register.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x16(__m512i);

/// Sixteen lane masks: bit `l` for lane `l`.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M32x16(__mmask16);

impl fmt::Debug for F32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x16({:?})", self.to_array())
    }
}

impl fmt::Debug for I32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x16({:?})", self.to_array())
    }
}

impl fmt::Debug for M32x16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M32x16({:#018b})", self.0)
    }
}

/// The low 64 bits `n`, as the shift instructions take their count.
#[inline(always)]
fn count(n: u32) -> __m128i {
    unsafe { _mm_cvtsi64_si128(n as i64) }
}

/// The sign bit of every lane.
#[inline(always)]
fn sign_bits() -> __m512i {
    unsafe { _mm512_set1_epi32(i32::MIN) }
}

impl BitAnd for M32x16 {
    type Output = M32x16;
    #[inline(always)]
    fn bitand(self, o: M32x16) -> M32x16 {
        M32x16(self.0 & o.0)
    }
}

impl BitOr for M32x16 {
    type Output = M32x16;
    #[inline(always)]
    fn bitor(self, o: M32x16) -> M32x16 {
        M32x16(self.0 | o.0)
    }
}

impl BitXor for M32x16 {
    type Output = M32x16;
    #[inline(always)]
    fn bitxor(self, o: M32x16) -> M32x16 {
        M32x16(self.0 ^ o.0)
    }
}

impl Not for M32x16 {
    type Output = M32x16;
    #[inline(always)]
    fn not(self) -> M32x16 {
        M32x16(!self.0)
    }
}

impl Mask for M32x16 {
    #[inline(always)]
    fn splat(b: bool) -> M32x16 {
        M32x16(if b { 0xffff } else { 0 })
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.0 != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.0 == 0xffff
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        u32::from(self.0)
    }
}

impl BitAnd for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn bitand(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_and_si512(self.0, o.0)) }
    }
}

impl BitOr for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn bitor(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_or_si512(self.0, o.0)) }
    }
}

impl BitXor for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn bitxor(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_xor_si512(self.0, o.0)) }
    }
}

impl Not for I32x16 {
    type Output = I32x16;
    #[inline(always)]
    fn not(self) -> I32x16 {
        unsafe { I32x16(_mm512_xor_si512(self.0, _mm512_set1_epi32(-1))) }
    }
}

impl Int for I32x16 {
    type Mask = M32x16;
    type Array = [i32; 16];

    #[inline(always)]
    fn splat(v: i32) -> I32x16 {
        unsafe { I32x16(_mm512_set1_epi32(v)) }
    }
    #[inline(always)]
    fn from_array(a: [i32; 16]) -> I32x16 {
        // SAFETY: AVX-512F (see the top of the file); `a` is 64 readable
        // bytes and loadu takes any alignment.
        unsafe { I32x16(_mm512_loadu_epi32(a.as_ptr())) }
    }
    #[inline(always)]
    fn to_array(self) -> [i32; 16] {
        let mut a = [0; 16];
        // SAFETY: AVX-512F (see the top of the file); `a` is 64 writable
        // bytes and storeu takes any alignment.
        unsafe { _mm512_storeu_epi32(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn wrapping_add(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_add_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn wrapping_sub(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_sub_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn wrapping_mul(self, o: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_mullo_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn shift_left(self, n: u32) -> I32x16 {
        unsafe { I32x16(_mm512_sll_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn shift_right(self, n: u32) -> I32x16 {
        unsafe { I32x16(_mm512_sra_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn shift_right_logical(self, n: u32) -> I32x16 {
        unsafe { I32x16(_mm512_srl_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn cmp_eq(self, o: I32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmpeq_epi32_mask(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_gt(self, o: I32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmpgt_epi32_mask(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_lt(self, o: I32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmplt_epi32_mask(self.0, o.0)) }
    }
    #[inline(always)]
    fn select(m: M32x16, t: I32x16, f: I32x16) -> I32x16 {
        unsafe { I32x16(_mm512_mask_blend_epi32(m.0, f.0, t.0)) }
    }
}

macro_rules! binary_op {
    ($tr:ident, $method:ident, $intrinsic:ident) => {
        impl $tr for F32x16 {
            type Output = F32x16;
            #[inline(always)]
            fn $method(self, o: F32x16) -> F32x16 {
                unsafe { F32x16($intrinsic(self.0, o.0)) }
            }
        }
    };
}

binary_op!(Add, add, _mm512_add_ps);
binary_op!(Sub, sub, _mm512_sub_ps);
binary_op!(Mul, mul, _mm512_mul_ps);
binary_op!(Div, div, _mm512_div_ps);

impl Neg for F32x16 {
    type Output = F32x16;
    #[inline(always)]
    fn neg(self) -> F32x16 {
        F32x16::from_bits(I32x16(sign_bits()) ^ self.to_bits())
    }
}

impl Float for F32x16 {
    const WIDTH: usize = 16;
    const NAME: &'static str = "F32x16";
    type Mask = M32x16;
    type Int = I32x16;
    type Array = [f32; 16];

    #[inline(always)]
    fn splat(v: f32) -> F32x16 {
        unsafe { F32x16(_mm512_set1_ps(v)) }
    }
    #[inline(always)]
    fn from_array(a: [f32; 16]) -> F32x16 {
        F32x16::load(&a)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 16] {
        let mut a = [0.0; 16];
        self.store(&mut a);
        a
    }
    #[inline(always)]
    fn load(s: &[f32]) -> F32x16 {
        let s = &s[..16];
        // SAFETY: AVX-512F (see the top of the file); `s` is 16 readable
        // floats and loadu takes any alignment.
        unsafe { F32x16(_mm512_loadu_ps(s.as_ptr())) }
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        let out = &mut out[..16];
        // SAFETY: AVX-512F (see the top of the file); `out` is 16 writable
        // floats and storeu takes any alignment.
        unsafe { _mm512_storeu_ps(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mul_add(self, a: F32x16, b: F32x16) -> F32x16 {
        unsafe { F32x16(_mm512_fmadd_ps(self.0, a.0, b.0)) }
    }
    #[inline(always)]
    fn abs(self) -> F32x16 {
        unsafe { F32x16(_mm512_abs_ps(self.0)) }
    }
    #[inline(always)]
    fn min(self, o: F32x16) -> F32x16 {
        unsafe { F32x16(_mm512_min_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: F32x16) -> F32x16 {
        unsafe { F32x16(_mm512_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> F32x16 {
        unsafe { F32x16(_mm512_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn floor(self) -> F32x16 {
        unsafe { F32x16(_mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(self.0)) }
    }
    #[inline(always)]
    fn round_ties_even(self) -> F32x16 {
        unsafe { F32x16(_mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(self.0)) }
    }
    #[inline(always)]
    fn copysign(self, sign: F32x16) -> F32x16 {
        let s = I32x16(sign_bits());
        F32x16::from_bits((self.to_bits() & !s) | (sign.to_bits() & s))
    }
    #[inline(always)]
    fn mulsign(self, sign: F32x16) -> F32x16 {
        F32x16::from_bits(self.to_bits() ^ (sign.to_bits() & I32x16(sign_bits())))
    }
    #[inline(always)]
    fn cmp_eq(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_ne(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_lt(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_le(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_gt(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_ge(self, o: F32x16) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn is_nan(self) -> M32x16 {
        unsafe { M32x16(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0)) }
    }
    #[inline(always)]
    fn select(m: M32x16, t: F32x16, f: F32x16) -> F32x16 {
        unsafe { F32x16(_mm512_mask_blend_ps(m.0, f.0, t.0)) }
    }
    #[inline(always)]
    fn to_bits(self) -> I32x16 {
        unsafe { I32x16(_mm512_castps_si512(self.0)) }
    }
    #[inline(always)]
    fn from_bits(i: I32x16) -> F32x16 {
        unsafe { F32x16(_mm512_castsi512_ps(i.0)) }
    }
    #[inline(always)]
    fn to_int_trunc(self) -> I32x16 {
        unsafe { I32x16(_mm512_cvttps_epi32(self.0)) }
    }
    #[inline(always)]
    fn from_int(i: I32x16) -> F32x16 {
        unsafe { F32x16(_mm512_cvtepi32_ps(i.0)) }
    }
    #[inline(always)]
    fn gather_table(table: &[f32], i: I32x16) -> F32x16 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize, "a gather from {} floats", table.len());
        // SAFETY: AVX-512F (see the top of the file); the unsigned minimum
        // puts every index (a negative one reads as at least 2^31) in
        // 0..table.len(), so each lane reads one float of `table`.
        unsafe {
            let i = _mm512_min_epu32(i.0, _mm512_set1_epi32(table.len() as i32 - 1));
            F32x16(_mm512_i32gather_ps::<4>(i, table.as_ptr()))
        }
    }
}
