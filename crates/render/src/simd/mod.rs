//! f32 lanes for code written once and run one value at a time or eight or
//! sixteen at once: the [`Float`] trait with its [`Mask`] and [`Int`] lane
//! types, its instances, and elementary functions generic over it
//! ([`sin`], [`cos`], [`sin_cos`], [`exp`], [`ln`], [`erf`], [`atan`],
//! [`atan2`], [`acos`]).
//!
//! Instances:
//!
//! - `f32` (with `bool` masks and `i32` integers), [`Float::WIDTH`] 1: always
//!   compiled, the reference;
//! - [`F32x8`] (with [`M32x8`], [`I32x8`]): one AVX register, compiled where
//!   the target has AVX2 and FMA;
//! - [`F32x16`] (with [`M32x16`], [`I32x16`]): one AVX-512 register, compiled
//!   where the target has AVX-512F.
//!
//! The build uses `target-cpu=native`, so the instances compiled in are those
//! of the machine that builds.
//!
//! **Every lane of a SIMD evaluation is bitwise the scalar evaluation of the
//! same input.** Each operation of the trait is defined as one IEEE operation
//! with round-to-nearest (add, sub, mul, div, sqrt, a fused `mul_add`), an
//! exact one (abs, neg, floor, comparisons, selects, bit operations), or one
//! whose special cases are spelled out and mirrored by the scalar instance
//! ([`Float::min`] / [`Float::max`] as `minps` / `maxps`,
//! [`Float::to_int_trunc`] as `cvttps2dq`). There are no approximate
//! reciprocals, and Rust never contracts `a * b + c` into a fused operation,
//! so generic code written with these operations gives the same bits
//! whichever instance runs it. The one thing left open is the payload of a
//! NaN result; tests compare NaNs as equal.
//!
//! Integer lanes ([`Int`]) wrap on overflow, as the vector instructions do,
//! and their comparisons give the same [`Mask`] type as the float
//! comparisons, so a test on a quadrant number can select between floats.

mod funcs;
mod scalar;
mod vec3;

// Documented on x86-64 even where the documentation build lacks the
// features (rustdoc does not see `target-cpu=native`).
#[cfg(all(target_arch = "x86_64", any(doc, all(target_feature = "avx2", target_feature = "fma"))))]
mod avx2;
#[cfg(all(target_arch = "x86_64", any(doc, target_feature = "avx512f")))]
mod avx512;

#[cfg(test)]
pub(crate) mod check;

#[cfg(all(target_arch = "x86_64", any(doc, all(target_feature = "avx2", target_feature = "fma"))))]
pub use avx2::{F32x8, I32x8, M32x8};
#[cfg(all(target_arch = "x86_64", any(doc, target_feature = "avx512f")))]
pub use avx512::{F32x16, I32x16, M32x16};
pub use funcs::{acos, atan, atan2, cos, erf, erfinv, exp, ln, sin, sin_cos, SIN_COS_MAX};
pub use vec3::V3;

/// The widest lane type this build has (for batch work with no scalar
/// order to keep, such as tables: any instance gives the same bits).
#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
pub type Widest = F32x16;
/// The widest lane type this build has (for batch work with no scalar
/// order to keep, such as tables: any instance gives the same bits).
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx512f"), target_feature = "avx2", target_feature = "fma"))]
pub type Widest = F32x8;
/// The widest lane type this build has (for batch work with no scalar
/// order to keep, such as tables: any instance gives the same bits).
#[cfg(not(all(
    target_arch = "x86_64",
    any(target_feature = "avx512f", all(target_feature = "avx2", target_feature = "fma"))
)))]
pub type Widest = f32;

use std::fmt::Debug;
use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};

/// Lane `l` = `f(l)` for every lane: the inputs of a lane stage gathered
/// from wherever each lane's path keeps them.
#[inline(always)]
pub fn gather<F: Float>(f: impl Fn(usize) -> f32) -> F {
    let mut a = F::Array::default();
    for (l, x) in a.as_mut().iter_mut().enumerate() {
        *x = f(l);
    }
    F::from_array(a)
}

/// Lane-wise booleans, the result of comparisons on [`Float`] and [`Int`].
pub trait Mask:
    Copy + Debug + BitAnd<Output = Self> + BitOr<Output = Self> + BitXor<Output = Self> + Not<Output = Self>
{
    /// Every lane `b`.
    fn splat(b: bool) -> Self;
    /// Whether any lane is set.
    fn any(self) -> bool;
    /// Whether every lane is set.
    fn all(self) -> bool;
    /// Bit `l` set where lane `l` is.
    fn bitmask(self) -> u32;
}

/// Lanes of i32 beside a [`Float`] of the same width: bit patterns and
/// small integers (quadrants, exponents). Addition and subtraction wrap.
pub trait Int:
    Copy + Debug + BitAnd<Output = Self> + BitOr<Output = Self> + BitXor<Output = Self> + Not<Output = Self>
{
    /// The comparisons' result, the same type as the [`Float`]'s.
    type Mask: Mask;
    /// `[i32; WIDTH]`.
    type Array: Copy + Default + Debug + AsRef<[i32]> + AsMut<[i32]>;

    /// Every lane `v`.
    fn splat(v: i32) -> Self;
    /// Lane `l` = `a[l]`.
    fn from_array(a: Self::Array) -> Self;
    /// The lanes in order.
    fn to_array(self) -> Self::Array;
    /// Lane-wise `self + o`, wrapping.
    fn wrapping_add(self, o: Self) -> Self;
    /// Lane-wise `self - o`, wrapping.
    fn wrapping_sub(self, o: Self) -> Self;
    /// Lane-wise `self * o`, wrapping (the low 32 bits, as `pmulld`).
    fn wrapping_mul(self, o: Self) -> Self;
    /// Lane-wise `self << n`; 0 for `n` ≥ 32 (as `pslld`).
    fn shift_left(self, n: u32) -> Self;
    /// Lane-wise arithmetic `self >> n`; the sign in every bit for `n` ≥ 32
    /// (as `psrad`).
    fn shift_right(self, n: u32) -> Self;
    /// Lane-wise logical `self >> n` (zeros shifted in); 0 for `n` ≥ 32 (as
    /// `psrld`).
    fn shift_right_logical(self, n: u32) -> Self;
    /// Lane-wise `self == o`.
    fn cmp_eq(self, o: Self) -> Self::Mask;
    /// Lane-wise `self > o` (signed).
    fn cmp_gt(self, o: Self) -> Self::Mask;
    /// Lane-wise `self < o` (signed).
    fn cmp_lt(self, o: Self) -> Self::Mask;
    /// Lane `l` = `if m[l] { t[l] } else { f[l] }`.
    fn select(m: Self::Mask, t: Self, f: Self) -> Self;
}

/// Lanes of f32: the scalar `f32` (one lane) or a SIMD register. Generic
/// code over this trait gives, lane by lane, the same bits with every
/// instance (see the [module documentation](self)).
///
/// Method names differ from `f32`'s inherent ones where the meaning does:
/// comparisons are `cmp_*`, [`Float::min`] and [`Float::max`] follow
/// `minps` / `maxps` (not IEEE minNum), and the bit casts use [`Int`].
/// On a concrete `f32` the inherent methods win, so call these as
/// `Float::max(x, y)` there.
pub trait Float:
    Copy
    + Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Lanes per value.
    const WIDTH: usize;
    /// The instance's name, for test output: `f32`, `F32x8`, `F32x16`.
    const NAME: &'static str;
    /// Lane-wise booleans.
    type Mask: Mask;
    /// i32 lanes of the same width, whose comparisons give [`Self::Mask`].
    type Int: Int<Mask = Self::Mask>;
    /// `[f32; WIDTH]`.
    type Array: Copy + Default + Debug + AsRef<[f32]> + AsMut<[f32]>;

    /// Every lane `v`.
    fn splat(v: f32) -> Self;
    /// Lane `l` = `a[l]`.
    fn from_array(a: Self::Array) -> Self;
    /// The lanes in order.
    fn to_array(self) -> Self::Array;
    /// Lane `l` = `s[l]`, from the first [`Float::WIDTH`] elements.
    ///
    /// # Panics
    /// If `s` is shorter than [`Float::WIDTH`].
    fn load(s: &[f32]) -> Self;
    /// Writes lane `l` to `out[l]` for the first [`Float::WIDTH`] elements.
    ///
    /// # Panics
    /// If `out` is shorter than [`Float::WIDTH`].
    fn store(self, out: &mut [f32]);

    /// Lane-wise `self * a + b`, rounded once (`f32::mul_add`, `vfmadd`).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// Lane-wise |self| (the sign bit cleared, NaNs included).
    fn abs(self) -> Self;
    /// Lane-wise `if self < o { self } else { o }`, as `minps`: `o` where
    /// either is NaN, and `o` for two zeros of either sign.
    fn min(self, o: Self) -> Self;
    /// Lane-wise `if self > o { self } else { o }`, as `maxps`: `o` where
    /// either is NaN, and `o` for two zeros of either sign.
    fn max(self, o: Self) -> Self;
    /// Lane-wise √self, correctly rounded; NaN below −0.
    fn sqrt(self) -> Self;
    /// Lane-wise ⌊self⌋ (exact; −0, infinities and NaN kept).
    fn floor(self) -> Self;
    /// Lane-wise nearest integer, ties to even (exact; −0, infinities and
    /// NaN kept).
    fn round_ties_even(self) -> Self;
    /// Lane-wise |self| with the sign bit of `sign` (NaNs included).
    fn copysign(self, sign: Self) -> Self;
    /// Lane-wise `self` with its sign bit flipped where `sign`'s is set:
    /// `self` times the sign of `sign`, exactly.
    fn mulsign(self, sign: Self) -> Self;

    /// Lane-wise `self == o` (false where either is NaN).
    fn cmp_eq(self, o: Self) -> Self::Mask;
    /// Lane-wise `self != o` (true where either is NaN).
    fn cmp_ne(self, o: Self) -> Self::Mask;
    /// Lane-wise `self < o` (false where either is NaN).
    fn cmp_lt(self, o: Self) -> Self::Mask;
    /// Lane-wise `self <= o` (false where either is NaN).
    fn cmp_le(self, o: Self) -> Self::Mask;
    /// Lane-wise `self > o` (false where either is NaN).
    fn cmp_gt(self, o: Self) -> Self::Mask;
    /// Lane-wise `self >= o` (false where either is NaN).
    fn cmp_ge(self, o: Self) -> Self::Mask;
    /// Lanes that are NaN.
    fn is_nan(self) -> Self::Mask;
    /// Lane `l` = `if m[l] { t[l] } else { f[l] }`.
    fn select(m: Self::Mask, t: Self, f: Self) -> Self;

    /// The lanes' bit patterns (`f32::to_bits`).
    fn to_bits(self) -> Self::Int;
    /// Floats from bit patterns (`f32::from_bits`).
    fn from_bits(i: Self::Int) -> Self;
    /// Lane-wise conversion to i32 rounding towards zero, as `cvttps2dq`:
    /// `i32::MIN` for NaN and outside [−2³¹, 2³¹) (not saturating like `as`).
    fn to_int_trunc(self) -> Self::Int;
    /// Lane-wise conversion from i32, rounded to nearest (as `as f32`).
    fn from_int(i: Self::Int) -> Self;
    /// Lane `l` = `table[i[l]]`, read by the hardware gather (`vgatherdps`)
    /// in SIMD instances: the table loads of a lane stage without a scalar
    /// loop. An index outside the table (negative ones included) reads its
    /// last element, so no lane ever reads outside it.
    ///
    /// # Panics
    /// If `table` is empty or longer than `i32::MAX`.
    fn gather_table(table: &[f32], i: Self::Int) -> Self;
}

#[cfg(test)]
mod tests {
    use super::check::{check_kernel, each_simd, same, specials, Kernel, Rng, Visit};
    use super::{Float, Int, Mask};

    /// A [`Kernel`] from a body over arguments `a`, `b`, `c` of type `F`;
    /// `bits` compares results bit for bit, NaN payloads included.
    macro_rules! kernel {
        ($name:ident, $nan_equal:expr, |$a:ident, $b:ident, $c:ident| $body:expr) => {
            struct $name;
            impl Kernel for $name {
                const NAME: &'static str = stringify!($name);
                const NAN_EQUAL: bool = $nan_equal;
                #[allow(unused_variables)]
                fn eval<F: Float>($a: F, $b: F, $c: F) -> F {
                    $body
                }
            }
        };
    }

    fn one_zero<F: Float>(m: F::Mask) -> F {
        F::select(m, F::splat(1.0), F::splat(0.0))
    }

    fn bits<F: Float>(i: F::Int) -> F {
        F::from_bits(i)
    }

    // Float arithmetic: NaN results compare equal whatever their payload
    // (which operand's NaN survives depends on operand order, which the
    // compiler may swap for commutative operations).
    kernel!(Add, true, |a, b, c| a + b);
    kernel!(Sub, true, |a, b, c| a - b);
    kernel!(Mul, true, |a, b, c| a * b);
    kernel!(Div, true, |a, b, c| a / b);
    kernel!(MulAdd, true, |a, b, c| a.mul_add(b, c));
    kernel!(Sqrt, true, |a, b, c| a.sqrt());
    kernel!(Floor, true, |a, b, c| a.floor());
    kernel!(RoundTiesEven, true, |a, b, c| a.round_ties_even());
    kernel!(FromInt, true, |a, b, c| F::from_int(a.to_bits()));
    // Exact operations: bit for bit, NaNs included.
    kernel!(Neg, false, |a, b, c| -a);
    kernel!(Abs, false, |a, b, c| a.abs());
    kernel!(Min, false, |a, b, c| a.min(b));
    kernel!(Max, false, |a, b, c| a.max(b));
    kernel!(Copysign, false, |a, b, c| a.copysign(b));
    kernel!(Mulsign, false, |a, b, c| a.mulsign(b));
    kernel!(Select, false, |a, b, c| F::select(a.cmp_lt(b), c, a));
    kernel!(Bits, false, |a, b, c| F::from_bits(a.to_bits()));
    kernel!(ToIntTrunc, false, |a, b, c| bits::<F>(a.to_int_trunc()));
    kernel!(CmpEq, false, |a, b, c| one_zero::<F>(a.cmp_eq(b)));
    kernel!(CmpNe, false, |a, b, c| one_zero::<F>(a.cmp_ne(b)));
    kernel!(CmpLt, false, |a, b, c| one_zero::<F>(a.cmp_lt(b)));
    kernel!(CmpLe, false, |a, b, c| one_zero::<F>(a.cmp_le(b)));
    kernel!(CmpGt, false, |a, b, c| one_zero::<F>(a.cmp_gt(b)));
    kernel!(CmpGe, false, |a, b, c| one_zero::<F>(a.cmp_ge(b)));
    kernel!(IsNan, false, |a, b, c| one_zero::<F>(a.is_nan()));
    // Masks: the four combinations of two comparisons as bits 0..4 of an
    // integer lane.
    kernel!(MaskOps, false, |a, b, c| {
        let (m, n) = (a.cmp_lt(b), c.cmp_ge(b));
        let bit = |m: F::Mask, v: i32| F::Int::select(m, F::Int::splat(v), F::Int::splat(0));
        bits::<F>(bit(m & n, 1) | bit(m | n, 2) | bit(m ^ n, 4) | bit(!m, 8) | bit(F::Mask::splat(true), 16))
    });
    // Integer lanes on the arguments' bit patterns.
    kernel!(IntAdd, false, |a, b, c| bits::<F>(a.to_bits().wrapping_add(b.to_bits())));
    kernel!(IntSub, false, |a, b, c| bits::<F>(a.to_bits().wrapping_sub(b.to_bits())));
    kernel!(IntMul, false, |a, b, c| bits::<F>(a.to_bits().wrapping_mul(b.to_bits())));
    kernel!(IntAnd, false, |a, b, c| bits::<F>(a.to_bits() & b.to_bits()));
    kernel!(IntOr, false, |a, b, c| bits::<F>(a.to_bits() | b.to_bits()));
    kernel!(IntXor, false, |a, b, c| bits::<F>(a.to_bits() ^ b.to_bits()));
    kernel!(IntNot, false, |a, b, c| bits::<F>(!a.to_bits()));
    kernel!(IntCmpEq, false, |a, b, c| one_zero::<F>(a.to_bits().cmp_eq(b.to_bits())));
    kernel!(IntCmpGt, false, |a, b, c| one_zero::<F>(a.to_bits().cmp_gt(b.to_bits())));
    kernel!(IntCmpLt, false, |a, b, c| one_zero::<F>(a.to_bits().cmp_lt(b.to_bits())));
    kernel!(IntSelect, false, |a, b, c| bits::<F>(F::Int::select(
        a.to_bits().cmp_lt(b.to_bits()),
        c.to_bits(),
        a.to_bits()
    )));
    kernel!(IntSplat, false, |a, b, c| bits::<F>(F::Int::splat(-123_456_789) ^ a.to_bits()));

    /// Shifts by `N` (the same count in every lane).
    struct Shifts<const N: u32>;
    impl<const N: u32> Kernel for Shifts<N> {
        const NAME: &'static str = "shifts";
        const NAN_EQUAL: bool = false;
        fn eval<F: Float>(a: F, b: F, c: F) -> F {
            let _ = c;
            let i = a.to_bits();
            let s = i.shift_left(N) ^ b.to_bits().shift_right(N);
            let t = F::Int::select(a.cmp_lt(b), i.shift_right_logical(N), s);
            F::from_bits(t)
        }
    }

    /// Triples: every pair of the specials (third argument from the pair,
    /// for the mask kernels), then random: any bit patterns, uniform
    /// values, equal or opposite pairs, and products whose fused and
    /// unfused values differ (c = −round(a·b)).
    fn args(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let sp = specials(&[]);
        let mut v = Vec::new();
        for (i, &a) in sp.iter().enumerate().step_by(3) {
            for (j, &b) in sp.iter().enumerate().step_by(3) {
                v.push([a, b, sp[(i * 7 + j) % sp.len()]]);
            }
        }
        let mut rng = Rng::new(seed);
        while v.len() < n {
            let pick = |rng: &mut Rng| match rng.next_u64() % 3 {
                0 => rng.bits(),
                1 => rng.uniform(-8.0, 8.0),
                _ => sp[(rng.next_u64() % sp.len() as u64) as usize],
            };
            let (a, b) = (pick(&mut rng), pick(&mut rng));
            let c = match rng.next_u64() % 4 {
                0 => -(a * b),
                1 => a,
                _ => pick(&mut rng),
            };
            v.push(match rng.next_u64() % 8 {
                0 => [a, a, c],
                1 => [a, -a, c],
                _ => [a, b, c],
            });
        }
        v
    }

    /// (c) Every operation of the trait on every SIMD instance equals the
    /// scalar one, bit for bit, over 10⁵ argument triples.
    #[test]
    fn operations_equal_scalar() {
        let v = args(100_000, 7);
        let mut ran = vec![
            check_kernel::<Add>(&v),
            check_kernel::<Sub>(&v),
            check_kernel::<Mul>(&v),
            check_kernel::<Div>(&v),
            check_kernel::<MulAdd>(&v),
            check_kernel::<Sqrt>(&v),
            check_kernel::<Floor>(&v),
            check_kernel::<RoundTiesEven>(&v),
            check_kernel::<FromInt>(&v),
            check_kernel::<Neg>(&v),
            check_kernel::<Abs>(&v),
            check_kernel::<Min>(&v),
            check_kernel::<Max>(&v),
            check_kernel::<Copysign>(&v),
            check_kernel::<Mulsign>(&v),
            check_kernel::<Select>(&v),
            check_kernel::<Bits>(&v),
            check_kernel::<ToIntTrunc>(&v),
            check_kernel::<CmpEq>(&v),
            check_kernel::<CmpNe>(&v),
            check_kernel::<CmpLt>(&v),
            check_kernel::<CmpLe>(&v),
            check_kernel::<CmpGt>(&v),
            check_kernel::<CmpGe>(&v),
            check_kernel::<IsNan>(&v),
            check_kernel::<MaskOps>(&v),
            check_kernel::<IntAdd>(&v),
            check_kernel::<IntSub>(&v),
            check_kernel::<IntMul>(&v),
            check_kernel::<IntAnd>(&v),
            check_kernel::<IntOr>(&v),
            check_kernel::<IntXor>(&v),
            check_kernel::<IntNot>(&v),
            check_kernel::<IntCmpEq>(&v),
            check_kernel::<IntCmpGt>(&v),
            check_kernel::<IntCmpLt>(&v),
            check_kernel::<IntSelect>(&v),
            check_kernel::<IntSplat>(&v),
        ];
        ran.push(check_kernel::<Shifts<0>>(&v));
        ran.push(check_kernel::<Shifts<1>>(&v));
        ran.push(check_kernel::<Shifts<7>>(&v));
        ran.push(check_kernel::<Shifts<23>>(&v));
        ran.push(check_kernel::<Shifts<31>>(&v));
        ran.push(check_kernel::<Shifts<32>>(&v));
        ran.push(check_kernel::<Shifts<33>>(&v));
        ran.push(check_kernel::<Shifts<200>>(&v));
        println!("instances tested besides f32: {:?}", ran[0]);
        assert!(ran.iter().all(|r| *r == ran[0]));
    }

    /// The scalar instance's definitions, which the SIMD instructions'
    /// special cases fix: min/max return the second operand for NaNs and
    /// zero pairs, the truncating conversion gives i32::MIN out of range,
    /// shifts by 32 or more fill, mul_add rounds once.
    #[test]
    fn scalar_definitions() {
        let nan = f32::NAN;
        assert!(same(Float::min(nan, 1.0), 1.0, false) && Float::min(1.0, nan).is_nan());
        assert!(same(Float::max(nan, 1.0), 1.0, false) && Float::max(1.0, nan).is_nan());
        assert!(same(Float::min(-0.0, 0.0), 0.0, false) && same(Float::min(0.0, -0.0), -0.0, false));
        assert!(same(Float::max(-0.0, 0.0), 0.0, false) && same(Float::max(0.0, -0.0), -0.0, false));
        assert_eq!((Float::min(1.0f32, 2.0), Float::max(1.0f32, 2.0)), (1.0, 2.0));
        for x in [nan, 3e9, -3e9, 2_147_483_648.0, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(x.to_int_trunc(), i32::MIN, "{x}");
        }
        assert_eq!(
            (-2.7f32.to_int_trunc(), 2.7f32.to_int_trunc(), (-2_147_483_648.0f32).to_int_trunc()),
            (-2, 2, i32::MIN)
        );
        assert_eq!(2_147_483_520.0f32.to_int_trunc(), 2_147_483_520);
        assert_eq!(
            (Int::shift_left(-1i32, 31), Int::shift_left(-1i32, 32), Int::shift_left(5i32, 100)),
            (i32::MIN, 0, 0)
        );
        assert_eq!((Int::shift_right(-8i32, 2), Int::shift_right(-8i32, 40), Int::shift_right(8i32, 40)), (-2, -1, 0));
        assert_eq!((Int::shift_right_logical(-1i32, 28), Int::shift_right_logical(-1i32, 32)), (15, 0));
        assert_eq!((Int::wrapping_add(i32::MAX, 1), Int::wrapping_sub(i32::MIN, 1)), (i32::MIN, i32::MAX));
        assert!(same(Float::mulsign(2.0f32, -0.0), -2.0, false) && same(Float::mulsign(-2.0f32, -1.0), 2.0, false));
        assert!(same(Float::copysign(nan, -1.0), -nan, false));
        assert!(same(2.5f32.round_ties_even(), 2.0, false) && same((-0.5f32).round_ties_even(), -0.0, false));
        let (x, y, z) = (0.1f32, 3.0f32, -0.3f32);
        assert_ne!(Float::mul_add(x, y, z), x * y + z);
        assert_eq!(Float::mul_add(x, y, z) as f64, x as f64 * y as f64 + z as f64);
    }

    /// A load from or a store to a slice one shorter than the lanes.
    fn short<F: Float>(store: bool) {
        let mut v = vec![0.0; F::WIDTH - 1];
        if store {
            F::splat(1.0).store(&mut v);
        } else {
            F::load(&v);
        }
    }

    #[test]
    #[should_panic]
    fn short_load_f32() {
        short::<f32>(false);
    }
    #[test]
    #[should_panic]
    fn short_store_f32() {
        short::<f32>(true);
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    #[test]
    #[should_panic]
    fn short_load_f32x8() {
        short::<super::F32x8>(false);
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    #[test]
    #[should_panic]
    fn short_store_f32x8() {
        short::<super::F32x8>(true);
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    #[test]
    #[should_panic]
    fn short_load_f32x16() {
        short::<super::F32x16>(false);
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    #[test]
    #[should_panic]
    fn short_store_f32x16() {
        short::<super::F32x16>(true);
    }

    /// Loads, stores, arrays and mask reductions on every instance.
    #[test]
    fn lanes_and_masks() {
        struct V;
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                let w = F::WIDTH;
                let src: Vec<f32> = (0..w + 5).map(|i| i as f32 * 1.5 - 3.0).collect();
                for off in 0..5 {
                    let x = F::load(&src[off..]);
                    assert_eq!(x.to_array().as_ref(), &src[off..off + w], "{} load", F::NAME);
                    let mut out = vec![f32::NAN; w + 5];
                    x.store(&mut out[off..]);
                    assert_eq!(&out[off..off + w], &src[off..off + w], "{} store", F::NAME);
                    assert!(
                        out[..off].iter().chain(&out[off + w..]).all(|v| v.is_nan()),
                        "{} store wrote outside",
                        F::NAME
                    );
                    assert_eq!(F::from_array(x.to_array()).to_array().as_ref(), &src[off..off + w]);
                }
                let mut ints = <F::Int as Int>::Array::default();
                for (l, v) in ints.as_mut().iter_mut().enumerate() {
                    *v = l as i32 * 1_000_003 - 7;
                }
                assert_eq!(F::Int::from_array(ints).to_array().as_ref(), ints.as_ref());
                let full = if w == 32 { u32::MAX } else { (1u32 << w) - 1 };
                assert_eq!(F::Mask::splat(true).bitmask(), full);
                assert_eq!(F::Mask::splat(false).bitmask(), 0);
                let mut rng = Rng::new(w as u64);
                for _ in 0..2000 {
                    let (mut a, mut b) = (F::Array::default(), F::Array::default());
                    let mut want = 0u32;
                    for l in 0..w {
                        // Lane patterns from all-false to all-true.
                        let (x, y) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0) * (rng.next_u64() % 3) as f32);
                        a.as_mut()[l] = x;
                        b.as_mut()[l] = y;
                        want |= ((x < y) as u32) << l;
                    }
                    let m = F::from_array(a).cmp_lt(F::from_array(b));
                    assert_eq!(m.bitmask(), want, "{} bitmask", F::NAME);
                    assert_eq!((m.any(), m.all()), (want != 0, want == full), "{} any/all", F::NAME);
                    assert_eq!((!m).bitmask(), full & !want, "{} not", F::NAME);
                }
            }
        }
        let ran = each_simd(&mut V);
        V.visit::<f32>();
        println!("lanes and masks: f32 and {ran:?}");
    }

    /// `gather_table` reads `table[i]` per lane on every instance, and an
    /// index outside the table (past its end, negative, `i32::MIN`) reads
    /// its last element.
    #[test]
    fn gather_reads_each_lane_index() {
        struct V;
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                let w = F::WIDTH;
                let table: Vec<f32> = (0..37).map(|i| i as f32 * 0.25 - 2.0).collect();
                let mut rng = Rng::new(17 + w as u64);
                for _ in 0..500 {
                    let mut idx = <F::Int as Int>::Array::default();
                    for v in idx.as_mut() {
                        *v = match rng.next_u64() % 8 {
                            0 => 37 + (rng.next_u64() % 1000) as i32,
                            1 => -1 - (rng.next_u64() % 1000) as i32,
                            2 => i32::MIN,
                            _ => (rng.next_u64() % 37) as i32,
                        };
                    }
                    let got = F::gather_table(&table, F::Int::from_array(idx)).to_array();
                    for (l, &i) in idx.as_ref().iter().enumerate() {
                        let want = if (0..37).contains(&i) { table[i as usize] } else { table[36] };
                        assert_eq!(got.as_ref()[l].to_bits(), want.to_bits(), "{} lane {l} index {i}", F::NAME);
                    }
                }
            }
        }
        let ran = each_simd(&mut V);
        V.visit::<f32>();
        println!("gathers: f32 and {ran:?}");
    }

    #[test]
    #[should_panic]
    fn gather_from_nothing() {
        f32::gather_table(&[], 0);
    }
}
