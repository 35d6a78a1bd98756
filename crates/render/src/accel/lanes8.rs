//! Eight f32 lanes: one AVX register where the target has AVX (the build
//! uses `target-cpu=native`), else two SSE halves. Only what the 8-wide box
//! test needs, including the dequantisation of its byte-quantised planes.

#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
mod imp {
    use std::arch::x86_64::*;

    /// Eight f32 lanes in one AVX register.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F8(__m256);

    // SAFETY (all blocks below): the intrinsics need only AVX, which the
    // `cfg` above guarantees at compile time.
    impl F8 {
        /// All lanes `v`.
        #[inline(always)]
        pub fn splat(v: f32) -> F8 {
            unsafe { F8(_mm256_set1_ps(v)) }
        }
        /// Lane `l` = `a[l]`.
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> F8 {
            unsafe { F8(_mm256_loadu_ps(a.as_ptr())) }
        }
        /// The lanes in order.
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let mut a = [0.0; 8];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        // Named methods, not operator traits: the lane types stay plain and `#[inline(always)]`.
        /// Lane-wise `self - o`.
        #[allow(clippy::should_implement_trait)]
        #[inline(always)]
        pub fn sub(self, o: F8) -> F8 {
            unsafe { F8(_mm256_sub_ps(self.0, o.0)) }
        }
        /// Lane-wise `self * o`.
        #[allow(clippy::should_implement_trait)]
        #[inline(always)]
        pub fn mul(self, o: F8) -> F8 {
            unsafe { F8(_mm256_mul_ps(self.0, o.0)) }
        }
        /// Lane-wise `self * a + b`, rounded once (the same value as
        /// `f32::mul_add` per lane, which the quantised boxes rely on).
        #[inline(always)]
        pub fn mul_add(self, a: F8, b: F8) -> F8 {
            #[cfg(target_feature = "fma")]
            unsafe {
                F8(_mm256_fmadd_ps(self.0, a.0, b.0))
            }
            #[cfg(not(target_feature = "fma"))]
            {
                let (x, y, z) = (self.to_array(), a.to_array(), b.to_array());
                F8::from_array(std::array::from_fn(|l| x[l].mul_add(y[l], z[l])))
            }
        }
        /// Eight bytes as floats 0..=255.
        #[inline(always)]
        pub fn from_u8(q: &[u8; 8]) -> F8 {
            #[cfg(target_feature = "avx2")]
            unsafe {
                let b = _mm_loadl_epi64(q.as_ptr() as *const __m128i);
                F8(_mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b)))
            }
            #[cfg(not(target_feature = "avx2"))]
            {
                F8::from_array(q.map(f32::from))
            }
        }
        /// Lane-wise maximum; like `maxps`, returns `o` where either is NaN.
        #[inline(always)]
        pub fn max(self, o: F8) -> F8 {
            unsafe { F8(_mm256_max_ps(self.0, o.0)) }
        }
        /// Lane-wise minimum; like `minps`, returns `o` where either is NaN.
        #[inline(always)]
        pub fn min(self, o: F8) -> F8 {
            unsafe { F8(_mm256_min_ps(self.0, o.0)) }
        }
        /// Bit `l` set where lane `l` of `self` <= lane `l` of `o` (false for NaN).
        #[inline(always)]
        pub fn le_mask(self, o: F8) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) as u32 }
        }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
mod imp {
    use glam::Vec4;

    /// Eight f32 lanes as two SSE-width halves (lanes 0..4, 4..8).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct F8([Vec4; 2]);

    impl F8 {
        /// All lanes `v`.
        #[inline(always)]
        pub fn splat(v: f32) -> F8 {
            F8([Vec4::splat(v); 2])
        }
        /// Lane `l` = `a[l]`.
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> F8 {
            F8([Vec4::new(a[0], a[1], a[2], a[3]), Vec4::new(a[4], a[5], a[6], a[7])])
        }
        /// The lanes in order.
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let (l, h) = (self.0[0].to_array(), self.0[1].to_array());
            [l[0], l[1], l[2], l[3], h[0], h[1], h[2], h[3]]
        }
        /// Lane-wise `self - o`.
        #[inline(always)]
        pub fn sub(self, o: F8) -> F8 {
            F8([self.0[0] - o.0[0], self.0[1] - o.0[1]])
        }
        /// Lane-wise `self * o`.
        #[inline(always)]
        pub fn mul(self, o: F8) -> F8 {
            F8([self.0[0] * o.0[0], self.0[1] * o.0[1]])
        }
        /// Lane-wise `self * a + b`, rounded once (as `f32::mul_add`).
        #[inline(always)]
        pub fn mul_add(self, a: F8, b: F8) -> F8 {
            let (x, y, z) = (self.to_array(), a.to_array(), b.to_array());
            F8::from_array(std::array::from_fn(|l| x[l].mul_add(y[l], z[l])))
        }
        /// Eight bytes as floats 0..=255.
        #[inline(always)]
        pub fn from_u8(q: &[u8; 8]) -> F8 {
            F8::from_array(q.map(f32::from))
        }
        /// Lane-wise maximum, returning `o` where either is NaN (as `maxps`).
        #[inline(always)]
        pub fn max(self, o: F8) -> F8 {
            let m = |a: Vec4, b: Vec4| Vec4::select(a.cmpgt(b), a, b);
            F8([m(self.0[0], o.0[0]), m(self.0[1], o.0[1])])
        }
        /// Lane-wise minimum, returning `o` where either is NaN (as `minps`).
        #[inline(always)]
        pub fn min(self, o: F8) -> F8 {
            let m = |a: Vec4, b: Vec4| Vec4::select(a.cmplt(b), a, b);
            F8([m(self.0[0], o.0[0]), m(self.0[1], o.0[1])])
        }
        /// Bit `l` set where lane `l` of `self` <= lane `l` of `o` (false for NaN).
        #[inline(always)]
        pub fn le_mask(self, o: F8) -> u32 {
            self.0[0].cmple(o.0[0]).bitmask() | (self.0[1].cmple(o.0[1]).bitmask() << 4)
        }
    }
}

pub use imp::F8;

#[cfg(test)]
mod tests {
    use super::F8;

    #[test]
    fn lane_operations() {
        let a = F8::from_array([1.0, -2.0, 3.0, f32::NAN, 5.0, 0.0, -7.0, 8.0]);
        let b = F8::splat(2.0);
        assert_eq!(a.sub(b).to_array()[..3], [-1.0, -4.0, 1.0]);
        assert_eq!(a.mul(b).to_array()[7], 16.0);
        // NaN lanes take the second operand, as the box test relies on.
        assert_eq!(a.max(b).to_array(), [2.0, 2.0, 3.0, 2.0, 5.0, 2.0, 2.0, 8.0]);
        assert_eq!(a.min(b).to_array(), [1.0, -2.0, 2.0, 2.0, 2.0, 0.0, -7.0, 2.0]);
        assert_eq!(a.le_mask(b), 0b0110_0011);
        let q = F8::from_u8(&[0, 1, 2, 3, 127, 128, 254, 255]);
        assert_eq!(q.to_array(), [0.0, 1.0, 2.0, 3.0, 127.0, 128.0, 254.0, 255.0]);
        // Fused: one rounding (0.1 * 3 + -0.3 is not 0 when fused).
        let (x, y, z) = (0.1f32, 3.0f32, -0.3f32);
        assert_eq!(F8::splat(x).mul_add(F8::splat(y), F8::splat(z)).to_array()[0], x.mul_add(y, z));
    }
}
