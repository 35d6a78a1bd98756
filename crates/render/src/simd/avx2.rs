//! Eight lanes in one AVX register: [`F32x8`], [`I32x8`] and the mask
//! [`M32x8`] (all ones or all zeros per lane). Compiled only where the target
//! has AVX2 and FMA.

use super::{Float, Int, Mask};
use std::arch::x86_64::*;
use std::fmt;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

// SAFETY (every `unsafe` block in this file unless it says otherwise): the
// intrinsics called need only SSE2, AVX, AVX2 or FMA, which the `cfg` on this
// module guarantees at compile time, and touch no memory.

/// Eight f32 lanes in one AVX register.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F32x8(__m256);

/// Eight i32 lanes in one AVX register.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct I32x8(__m256i);

/// Eight lane masks in one AVX register: each lane all ones (set) or all
/// zeros, as AVX comparisons give them.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M32x8(__m256);

impl fmt::Debug for F32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F32x8({:?})", self.to_array())
    }
}

impl fmt::Debug for I32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I32x8({:?})", self.to_array())
    }
}

impl fmt::Debug for M32x8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M32x8({:#010b})", self.bitmask())
    }
}

/// All bits set in every lane.
#[inline(always)]
fn ones() -> __m256i {
    unsafe { _mm256_set1_epi32(-1) }
}

/// The low 64 bits `n`, as the shift instructions take their count.
#[inline(always)]
fn count(n: u32) -> __m128i {
    unsafe { _mm_cvtsi64_si128(n as i64) }
}

impl BitAnd for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn bitand(self, o: M32x8) -> M32x8 {
        unsafe { M32x8(_mm256_and_ps(self.0, o.0)) }
    }
}

impl BitOr for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn bitor(self, o: M32x8) -> M32x8 {
        unsafe { M32x8(_mm256_or_ps(self.0, o.0)) }
    }
}

impl BitXor for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn bitxor(self, o: M32x8) -> M32x8 {
        unsafe { M32x8(_mm256_xor_ps(self.0, o.0)) }
    }
}

impl Not for M32x8 {
    type Output = M32x8;
    #[inline(always)]
    fn not(self) -> M32x8 {
        unsafe { M32x8(_mm256_xor_ps(self.0, _mm256_castsi256_ps(ones()))) }
    }
}

impl Mask for M32x8 {
    #[inline(always)]
    fn splat(b: bool) -> M32x8 {
        unsafe { M32x8(_mm256_castsi256_ps(_mm256_set1_epi32(-(b as i32)))) }
    }
    #[inline(always)]
    fn any(self) -> bool {
        self.bitmask() != 0
    }
    #[inline(always)]
    fn all(self) -> bool {
        self.bitmask() == 0xff
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
}

impl BitAnd for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn bitand(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_and_si256(self.0, o.0)) }
    }
}

impl BitOr for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn bitor(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_or_si256(self.0, o.0)) }
    }
}

impl BitXor for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn bitxor(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_xor_si256(self.0, o.0)) }
    }
}

impl Not for I32x8 {
    type Output = I32x8;
    #[inline(always)]
    fn not(self) -> I32x8 {
        unsafe { I32x8(_mm256_xor_si256(self.0, ones())) }
    }
}

impl Int for I32x8 {
    type Mask = M32x8;
    type Array = [i32; 8];

    #[inline(always)]
    fn splat(v: i32) -> I32x8 {
        unsafe { I32x8(_mm256_set1_epi32(v)) }
    }
    #[inline(always)]
    fn from_array(a: [i32; 8]) -> I32x8 {
        // SAFETY: AVX (see the top of the file); `a` is 32 readable bytes and
        // loadu takes any alignment.
        unsafe { I32x8(_mm256_loadu_si256(a.as_ptr() as *const __m256i)) }
    }
    #[inline(always)]
    fn to_array(self) -> [i32; 8] {
        let mut a = [0; 8];
        // SAFETY: AVX (see the top of the file); `a` is 32 writable bytes and
        // storeu takes any alignment.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, self.0) };
        a
    }
    #[inline(always)]
    fn wrapping_add(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_add_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn wrapping_sub(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_sub_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn wrapping_mul(self, o: I32x8) -> I32x8 {
        unsafe { I32x8(_mm256_mullo_epi32(self.0, o.0)) }
    }
    #[inline(always)]
    fn shift_left(self, n: u32) -> I32x8 {
        unsafe { I32x8(_mm256_sll_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn shift_right(self, n: u32) -> I32x8 {
        unsafe { I32x8(_mm256_sra_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn shift_right_logical(self, n: u32) -> I32x8 {
        unsafe { I32x8(_mm256_srl_epi32(self.0, count(n))) }
    }
    #[inline(always)]
    fn cmp_eq(self, o: I32x8) -> M32x8 {
        unsafe { M32x8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, o.0))) }
    }
    #[inline(always)]
    fn cmp_gt(self, o: I32x8) -> M32x8 {
        unsafe { M32x8(_mm256_castsi256_ps(_mm256_cmpgt_epi32(self.0, o.0))) }
    }
    #[inline(always)]
    fn cmp_lt(self, o: I32x8) -> M32x8 {
        unsafe { M32x8(_mm256_castsi256_ps(_mm256_cmpgt_epi32(o.0, self.0))) }
    }
    #[inline(always)]
    fn select(m: M32x8, t: I32x8, f: I32x8) -> I32x8 {
        // Every byte of a mask lane carries the lane's bit.
        unsafe { I32x8(_mm256_blendv_epi8(f.0, t.0, _mm256_castps_si256(m.0))) }
    }
}

macro_rules! binary_op {
    ($tr:ident, $method:ident, $intrinsic:ident) => {
        impl $tr for F32x8 {
            type Output = F32x8;
            #[inline(always)]
            fn $method(self, o: F32x8) -> F32x8 {
                unsafe { F32x8($intrinsic(self.0, o.0)) }
            }
        }
    };
}

binary_op!(Add, add, _mm256_add_ps);
binary_op!(Sub, sub, _mm256_sub_ps);
binary_op!(Mul, mul, _mm256_mul_ps);
binary_op!(Div, div, _mm256_div_ps);

impl Neg for F32x8 {
    type Output = F32x8;
    #[inline(always)]
    fn neg(self) -> F32x8 {
        unsafe { F32x8(_mm256_xor_ps(self.0, _mm256_set1_ps(-0.0))) }
    }
}

impl Float for F32x8 {
    const WIDTH: usize = 8;
    const NAME: &'static str = "F32x8";
    type Mask = M32x8;
    type Int = I32x8;
    type Array = [f32; 8];

    #[inline(always)]
    fn splat(v: f32) -> F32x8 {
        unsafe { F32x8(_mm256_set1_ps(v)) }
    }
    #[inline(always)]
    fn from_array(a: [f32; 8]) -> F32x8 {
        F32x8::load(&a)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        let mut a = [0.0; 8];
        self.store(&mut a);
        a
    }
    #[inline(always)]
    fn load(s: &[f32]) -> F32x8 {
        let s = &s[..8];
        // SAFETY: AVX (see the top of the file); `s` is 8 readable floats and
        // loadu takes any alignment.
        unsafe { F32x8(_mm256_loadu_ps(s.as_ptr())) }
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        let out = &mut out[..8];
        // SAFETY: AVX (see the top of the file); `out` is 8 writable floats
        // and storeu takes any alignment.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mul_add(self, a: F32x8, b: F32x8) -> F32x8 {
        unsafe { F32x8(_mm256_fmadd_ps(self.0, a.0, b.0)) }
    }
    #[inline(always)]
    fn abs(self) -> F32x8 {
        unsafe { F32x8(_mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0)) }
    }
    #[inline(always)]
    fn min(self, o: F32x8) -> F32x8 {
        unsafe { F32x8(_mm256_min_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: F32x8) -> F32x8 {
        unsafe { F32x8(_mm256_max_ps(self.0, o.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> F32x8 {
        unsafe { F32x8(_mm256_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn floor(self) -> F32x8 {
        unsafe { F32x8(_mm256_round_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(self.0)) }
    }
    #[inline(always)]
    fn round_ties_even(self) -> F32x8 {
        unsafe { F32x8(_mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(self.0)) }
    }
    #[inline(always)]
    fn copysign(self, sign: F32x8) -> F32x8 {
        unsafe {
            let s = _mm256_set1_ps(-0.0);
            F32x8(_mm256_or_ps(_mm256_andnot_ps(s, self.0), _mm256_and_ps(s, sign.0)))
        }
    }
    #[inline(always)]
    fn mulsign(self, sign: F32x8) -> F32x8 {
        unsafe { F32x8(_mm256_xor_ps(self.0, _mm256_and_ps(_mm256_set1_ps(-0.0), sign.0))) }
    }
    #[inline(always)]
    fn cmp_eq(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_ne(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_lt(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_le(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_gt(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn cmp_ge(self, o: F32x8) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)) }
    }
    #[inline(always)]
    fn is_nan(self) -> M32x8 {
        unsafe { M32x8(_mm256_cmp_ps::<_CMP_UNORD_Q>(self.0, self.0)) }
    }
    #[inline(always)]
    fn select(m: M32x8, t: F32x8, f: F32x8) -> F32x8 {
        unsafe { F32x8(_mm256_blendv_ps(f.0, t.0, m.0)) }
    }
    #[inline(always)]
    fn to_bits(self) -> I32x8 {
        unsafe { I32x8(_mm256_castps_si256(self.0)) }
    }
    #[inline(always)]
    fn from_bits(i: I32x8) -> F32x8 {
        unsafe { F32x8(_mm256_castsi256_ps(i.0)) }
    }
    #[inline(always)]
    fn to_int_trunc(self) -> I32x8 {
        unsafe { I32x8(_mm256_cvttps_epi32(self.0)) }
    }
    #[inline(always)]
    fn from_int(i: I32x8) -> F32x8 {
        unsafe { F32x8(_mm256_cvtepi32_ps(i.0)) }
    }
    #[inline(always)]
    fn gather_table(table: &[f32], i: I32x8) -> F32x8 {
        assert!(!table.is_empty() && table.len() <= i32::MAX as usize, "a gather from {} floats", table.len());
        // SAFETY: AVX2 (see the top of the file); the unsigned minimum puts
        // every index (a negative one reads as at least 2^31) in
        // 0..table.len(), so each lane reads one float of `table`.
        unsafe {
            let i = _mm256_min_epu32(i.0, _mm256_set1_epi32(table.len() as i32 - 1));
            F32x8(_mm256_i32gather_ps::<4>(table.as_ptr(), i))
        }
    }
}
