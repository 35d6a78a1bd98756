//! Elementary functions written once over [`Float`]: branch-free (every
//! case computed and the lanes' results selected), so each lane of a SIMD
//! evaluation is bitwise the scalar evaluation of the same input.
//!
//! Sources and fusing: the trigonometric functions, `exp` and `ln` are
//! Cephes' single-precision ones (Moshier) with Horner steps fused by
//! [`Float::mul_add`] and Cody–Waite reductions by constants split into
//! three (π/2) or two (ln 2) full 24-bit parts, each subtracted with one
//! fused operation; `erf` is N. Juffa's faithfully rounded `erff` (Stack
//! Overflow answer 35148199), fused as published. `atan`, `atan2` and
//! `acos` are [`crate::math::fast`]'s, operation for operation (no fused
//! steps), so their `f32` instance is bitwise `math::fast`'s.
//!
//! Every error below is the largest measured against f64 references (std,
//! the C library's `erf`) in units in the last place of the correctly
//! rounded result (subnormal results in units of 2⁻¹⁴⁹), over every f32 of
//! the stated domain (the `#[ignore]`d `survey` test with
//! `PENUMBRA_SURVEY_STRIDE=1`; atan2 over 10⁷ random pairs). The `accuracy`
//! test checks each bound on about 10⁶ inputs per function.

use super::{Float, Int};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// All lanes `v`.
#[inline(always)]
fn c<F: Float>(v: f32) -> F {
    F::splat(v)
}

/// `coeffs[0]·xⁿ + … + coeffs[n]` by Horner's rule, each step fused.
#[inline(always)]
fn horner<F: Float>(x: F, coeffs: &[f32]) -> F {
    let mut r = c::<F>(coeffs[0]);
    for &k in &coeffs[1..] {
        r = r.mul_add(x, c(k));
    }
    r
}

/// π/2 as three f32 (hi + mid + lo within 1e-23 of π/2): `hi` is π/2
/// rounded (`FRAC_PI_2`, 0x3fc90fdb), `mid` the rest rounded, `lo` the rest
/// of that.
const PIO2_HI: f32 = FRAC_PI_2;
const PIO2_MID: f32 = -4.371_139e-8; // 0xb33bbd2e
const PIO2_LO: f32 = -1.715_124_5e-15; // 0xa6f72ced

/// Cephes `sinf`'s odd polynomial on [−π/4, π/4]: sin r ≈ r + r³·P(r²).
#[allow(clippy::excessive_precision)] // Cephes' published values, verbatim
const SIN_P: [f32; 3] = [-1.9515295891e-4, 8.3321608736e-3, -1.6666654611e-1];
/// Cephes `cosf`'s even polynomial on [−π/4, π/4]: cos r ≈ 1 − r²/2 + r⁴·Q(r²).
#[allow(clippy::excessive_precision)] // Cephes' published values, verbatim
const COS_Q: [f32; 3] = [2.443315711809948e-5, -1.388731625493765e-3, 4.166664568298827e-2];

/// The largest |x| [`sin`], [`cos`] and [`sin_cos`] accept, 2¹⁸ = 262144
/// (about 41722 turns); they return NaN beyond. The reduction stays
/// accurate a little further (the error passes 2 ulps near 2²⁰, where the
/// rounded quadrant estimate starts to leave |r| well beyond π/4).
pub const SIN_COS_MAX: f32 = 262_144.0;

/// sin and cos of `x` from one range reduction: `x` = q·π/2 + r with
/// |r| ≲ π/4, then sin r and cos r by Cephes' polynomials, swapped and
/// negated by the quadrant q mod 4.
#[inline(always)]
fn sin_cos_core<F: Float>(x: F) -> (F, F) {
    let a = x.abs();
    let y = (a * c(std::f32::consts::FRAC_2_PI)).round_ties_even();
    let q = y.to_int_trunc();
    // a − y·π/2 in three fused steps; the first is exact.
    let ny = -y;
    let r = ny.mul_add(c(PIO2_HI), a);
    let r = ny.mul_add(c(PIO2_MID), r);
    let r = ny.mul_add(c(PIO2_LO), r);
    let z = r * r;
    let s = horner(z, &SIN_P).mul_add(z * r, r);
    let co = horner(z, &COS_Q).mul_add(z * z, c::<F>(-0.5).mul_add(z, c(1.0)));
    let odd = (q & F::Int::splat(1)).cmp_eq(F::Int::splat(1));
    // Sign flips as bits: quadrants 2, 3 negate sin, quadrants 1, 2 cos.
    let sin_flip = (q & F::Int::splat(2)).shift_left(30);
    let cos_flip = (q.wrapping_add(F::Int::splat(1)) & F::Int::splat(2)).shift_left(30);
    let sin = F::from_bits(F::select(odd, co, s).to_bits() ^ sin_flip).mulsign(x);
    let cos = F::from_bits(F::select(odd, s, co).to_bits() ^ cos_flip);
    let out = a.cmp_gt(c(SIN_COS_MAX));
    (F::select(out, c(f32::NAN), sin), F::select(out, c(f32::NAN), cos))
}

/// sin x for |x| ≤ [`SIN_COS_MAX`]; NaN beyond, for ±∞ and for NaN.
/// sin(−0) = −0.
///
/// Cephes `sinf` with quadrants of π/2 (as Agner Fog's vector class
/// library arranges it). Max error 1.57 ulp for |x| ≤ [`SIN_COS_MAX`].
#[inline(always)]
pub fn sin<F: Float>(x: F) -> F {
    sin_cos_core(x).0
}

/// cos x for |x| ≤ [`SIN_COS_MAX`]; NaN beyond, for ±∞ and for NaN.
///
/// Cephes `cosf`, reduced as [`sin`]. Max error 1.59 ulp for |x| ≤
/// [`SIN_COS_MAX`].
#[inline(always)]
pub fn cos<F: Float>(x: F) -> F {
    sin_cos_core(x).1
}

/// (sin x, cos x) from one range reduction, bitwise ([`sin`]`(x)`,
/// [`cos`]`(x)`).
#[inline(always)]
pub fn sin_cos<F: Float>(x: F) -> (F, F) {
    sin_cos_core(x)
}

/// ln 2 as two f32: `hi` rounded (`LN_2`, 0x3f317218), `lo` the rest
/// (within 1e-16 of ln 2).
const LN2_HI: f32 = std::f32::consts::LN_2;
const LN2_LO: f32 = -1.904_654_2e-9; // 0xb102e308

/// Cephes `expf`'s polynomial on [−ln2/2, ln2/2]: eʳ ≈ 1 + r + r²·P(r).
#[allow(clippy::excessive_precision)] // Cephes' published values, verbatim
const EXP_P: [f32; 6] =
    [1.9875691500e-4, 1.3981999507e-3, 8.3334519073e-3, 4.1665795894e-2, 1.6666665459e-1, 5.0000001201e-1];

/// 2^e for e in [−126, 127], from the exponent bits.
#[inline(always)]
fn pow2i<F: Float>(e: F::Int) -> F {
    F::from_bits(e.wrapping_add(F::Int::splat(127)).shift_left(23))
}

/// eˣ: +∞ above ln(f32::MAX) ≈ 88.72, subnormal results down to
/// x ≈ −103.97, 0 below; NaN for NaN.
///
/// Cephes `expf`: x = q·ln 2 + r with |r| ≤ ln2/2, eʳ by a degree-7
/// polynomial, times 2^q in two factors (as SLEEF's `ldexp2kf`) so that
/// subnormal results round once. Max error 1.02 ulp on [−104, 89].
#[inline(always)]
pub fn exp<F: Float>(x: F) -> F {
    let y = (x * c(std::f32::consts::LOG2_E)).round_ties_even();
    let ny = -y;
    let r = ny.mul_add(c(LN2_HI), x);
    let r = ny.mul_add(c(LN2_LO), r);
    let e = (r * r).mul_add(horner(r, &EXP_P), r) + c(1.0);
    // |q| ≤ 150 where the result is used, so both halves are in range.
    let q = y.to_int_trunc();
    let q1 = q.shift_right(1);
    let e = e * pow2i::<F>(q1) * pow2i::<F>(q.wrapping_sub(q1));
    let e = F::select(x.cmp_gt(c(100.0)), c(f32::INFINITY), e);
    F::select(x.cmp_lt(c(-104.0)), c(0.0), e)
}

/// Cephes `logf`'s polynomial on [√½ − 1, √2 − 1]: ln(1 + m) ≈
/// m − m²/2 + m³·P(m).
#[allow(clippy::excessive_precision)] // Cephes' published values, verbatim
const LN_P: [f32; 9] = [
    7.0376836292e-2,
    -1.1514610310e-1,
    1.1676998740e-1,
    -1.2420140846e-1,
    1.4249322787e-1,
    -1.6668057665e-1,
    2.0000714765e-1,
    -2.4999993993e-1,
    3.3333331174e-1,
];

/// ln 2 as Cephes `logf` splits it: 0.693359375 (exact in 9 bits) −
/// 2.12194440e−4.
#[allow(clippy::excessive_precision)] // Cephes' published value, verbatim
const LN2_C1: f32 = 0.693359375;
#[allow(clippy::excessive_precision)] // Cephes' published value, verbatim
const LN2_C2: f32 = -2.12194440e-4;

/// ln x: −∞ for ±0, NaN below 0 and for NaN, +∞ for +∞; subnormal `x`
/// handled.
///
/// Cephes `logf`: x = 2ᵉ·(1 + m) with 1 + m in [√½, √2) from the bits
/// (subnormals scaled by 2²⁵ first), ln(1 + m) ≈ m − m²/2 + m³·P(m) with P
/// of degree 8, plus e·ln 2 in Cephes' two parts (0.693359375 −
/// 2.12194440e−4). Max error 0.83 ulp over all positive finite f32.
#[inline(always)]
pub fn ln<F: Float>(x: F) -> F {
    let sub = x.cmp_lt(c(f32::MIN_POSITIVE));
    let xs = F::select(sub, x * c(33_554_432.0), x);
    let bits = xs.to_bits();
    let e = (bits.shift_right_logical(23) & F::Int::splat(0xff)).wrapping_sub(F::Int::select(
        sub,
        F::Int::splat(126 + 25),
        F::Int::splat(126),
    ));
    // The mantissa as a float in [0.5, 1).
    let m = F::from_bits((bits & F::Int::splat(0x007f_ffff)) | F::Int::splat(0x3f00_0000));
    let low = m.cmp_lt(c(std::f32::consts::FRAC_1_SQRT_2));
    let e = F::from_int(F::Int::select(low, e.wrapping_sub(F::Int::splat(1)), e));
    let m = F::select(low, m + m, m) - c(1.0);
    let z = m * m;
    let y = horner(m, &LN_P) * m * z;
    let y = e.mul_add(c(LN2_C2), y);
    let y = z.mul_add(c(-0.5), y);
    let r = e.mul_add(c(LN2_C1), m + y);
    let r = F::select(x.cmp_eq(c(f32::INFINITY)), x, r);
    let r = F::select(x.cmp_ge(c(0.0)), r, c(f32::NAN));
    F::select(x.cmp_eq(c(0.0)), c(f32::NEG_INFINITY), r)
}

/// erf x, odd, ±1 beyond |x| ≈ 3.92; NaN for NaN.
///
/// N. Juffa's `erff` (Stack Overflow answer 35148199, 2016): x + x·P(x²)
/// for |x| ≤ 0.927734375, else 1 − e^(Q(|x|)) with the sign of x, Q of
/// degree 7 ending in −|x|; both fused as published, the exponential this
/// file's [`exp`]. Max error 1.03 ulp over all f32 (the published bound,
/// with a correctly rounded exponential, is just under 1).
#[inline(always)]
#[allow(clippy::excessive_precision)] // Juffa's published values, verbatim
pub fn erf<F: Float>(x: F) -> F {
    let t = x.abs();
    let s = x * x;
    let r = c::<F>(-1.72853470e-5).mul_add(t, c(3.83197126e-4));
    let u = c::<F>(-3.88396438e-3).mul_add(t, c(2.42546219e-2));
    let r = r.mul_add(s, u);
    let r = r.mul_add(t, c(-1.06777877e-1));
    let r = r.mul_add(t, c(-6.34846687e-1));
    let r = r.mul_add(t, c(-1.28717512e-1));
    let r = r.mul_add(t, -t);
    let tail = (c::<F>(1.0) - exp(r)).copysign(x);
    let near =
        horner(s, &[-5.96761703e-4, 4.99119423e-3, -2.67681349e-2, 1.12819925e-1, -3.76125336e-1, 1.28379166e-1])
            .mul_add(x, x);
    F::select(t.cmp_gt(c(0.927734375)), tail, near)
}

/// erf⁻¹ y on (−1, 1), odd; ±∞ at ±1, NaN outside. M. Giles'
/// single-precision approximation ("Approximating the erfinv function",
/// GPU Computing Gems, 2010): with w = −ln((1 − y)(1 + y)), y·P(w − 2.5)
/// for w < 5, else y·Q(√w − 3), both of degree 8, fused; the logarithm
/// this file's [`ln`]. Residual |erf(erfinv y) − y| below 4e-7 (test).
#[inline(always)]
#[allow(clippy::excessive_precision)] // Giles' published values, verbatim
pub fn erfinv<F: Float>(y: F) -> F {
    let w = -ln((c::<F>(1.0) - y) * (c::<F>(1.0) + y));
    let central = horner(
        w - c(2.5),
        &[
            2.81022636e-08,
            3.43273939e-07,
            -3.5233877e-06,
            -4.39150654e-06,
            0.00021858087,
            -0.00125372503,
            -0.00417768164,
            0.246640727,
            1.50140941,
        ],
    );
    let tail = horner(
        w.sqrt() - c(3.0),
        &[
            -0.000200214257,
            0.000100950558,
            0.00134934322,
            -0.00367342844,
            0.00573950773,
            -0.0076224613,
            0.00943887047,
            1.00167406,
            2.83297682,
        ],
    );
    let r = F::select(w.cmp_lt(c(5.0)), central, tail) * y;
    // At ±1 the polynomial in √w − 3 = ∞ has the wrong sign: ±∞ there.
    F::select(y.abs().cmp_eq(c(1.0)), y * c(f32::INFINITY), r)
}

/// arctan x, odd; ±π/2 for ±∞, NaN for NaN.
///
/// Cephes `atanf` as [`crate::math::fast::atan`], bitwise: reduced to
/// |t| ≤ tan(π/8) by atan x = π/4 + atan((x−1)/(x+1)) or π/2 − atan(1/x),
/// then an odd polynomial of degree 9, unfused. Max error 2.84 ulp over all
/// f32.
#[inline(always)]
pub fn atan<F: Float>(x: F) -> F {
    let a = x.abs();
    // tan(3π/8) and tan(π/8).
    let big = a.cmp_gt(c(2.414_213_6));
    let mid = a.cmp_gt(c(0.414_213_57));
    let base = F::select(big, c(FRAC_PI_2), F::select(mid, c(FRAC_PI_4), c(0.0)));
    // −1/a or (a − 1)/(a + 1) as one division.
    let num = F::select(big, c(-1.0), a - c(1.0));
    let den = F::select(big, a, a + c(1.0));
    let t = F::select(mid, num / den, a);
    let z = t * t;
    let p =
        (((c::<F>(8.053_744_5e-2) * z - c(1.387_768_6e-1)) * z + c(1.997_771_1e-1)) * z - c(3.333_295e-1)) * z * t + t;
    (base + p).copysign(x)
}

/// atan2(y, x) in [−π, π] as [`crate::math::fast::atan2`], bitwise: the
/// quadrant conventions of `f32::atan2` for non-zero `x` and finite
/// arguments, ±π/2 for x = ±0 and y ≠ 0, and 0 for (±0, ±0) (where
/// `f32::atan2` gives ±0 or ±π); NaN for two infinities (`f32::atan2`:
/// ±π/4, ±3π/4), and ±π/2 for y = NaN, x = ±0 (the sign bit of the NaN). Max
/// error 3.19 ulp over 10⁷ random pairs (points on circles of any radius,
/// any bit patterns; zero and infinite pairs left out).
#[inline(always)]
pub fn atan2<F: Float>(y: F, x: F) -> F {
    let r = atan(y / x);
    let r = F::select(x.cmp_gt(c(0.0)), r, r + c::<F>(PI).copysign(y));
    let axis = F::select(y.cmp_eq(c(0.0)), c(0.0), c::<F>(FRAC_PI_2).copysign(y));
    F::select(x.cmp_eq(c(0.0)), axis, r)
}

/// arccos x for x in [−1, 1], `x` clamped to it first (NaN kept), as
/// [`crate::math::fast::acos`], bitwise: atan(√(1 − x²)/|x|), reflected
/// for x < 0. Max error 3.73 ulp on [−1, 1].
#[inline(always)]
pub fn acos<F: Float>(x: F) -> F {
    // As f32::clamp: NaN passes through both.
    let x = c::<F>(1.0).min(c::<F>(-1.0).max(x));
    let s = ((c::<F>(1.0) - x) * (c::<F>(1.0) + x)).sqrt();
    let r = atan(s / x.abs());
    F::select(x.cmp_ge(c(0.0)), r, c::<F>(PI) - r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::fast;
    use crate::simd::check::{check_kernel, same, ulp_error, ulps_away, unary_args, Kernel, Rng};

    extern "C" {
        /// The C library's double-precision erf (std has no stable one).
        #[link_name = "erf"]
        fn libm_erf(x: f64) -> f64;
    }

    fn erf_ref(x: f64) -> f64 {
        // SAFETY: a pure C function of one double.
        unsafe { libm_erf(x) }
    }

    struct Sin;
    impl Kernel for Sin {
        const NAME: &'static str = "sin";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            sin(a)
        }
    }
    struct Cos;
    impl Kernel for Cos {
        const NAME: &'static str = "cos";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            cos(a)
        }
    }
    /// sin_cos's two results in one: sin where b < 0.5, else cos.
    struct SinCos;
    impl Kernel for SinCos {
        const NAME: &'static str = "sin_cos";
        fn eval<F: Float>(a: F, b: F, _: F) -> F {
            let (s, c) = sin_cos(a);
            F::select(b.cmp_lt(F::splat(0.5)), s, c)
        }
    }
    struct Exp;
    impl Kernel for Exp {
        const NAME: &'static str = "exp";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            exp(a)
        }
    }
    struct Ln;
    impl Kernel for Ln {
        const NAME: &'static str = "ln";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            ln(a)
        }
    }
    struct Erf;
    impl Kernel for Erf {
        const NAME: &'static str = "erf";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            erf(a)
        }
    }
    struct Erfinv;
    impl Kernel for Erfinv {
        const NAME: &'static str = "erfinv";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            erfinv(a)
        }
    }
    struct Atan;
    impl Kernel for Atan {
        const NAME: &'static str = "atan";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            atan(a)
        }
    }
    struct Atan2;
    impl Kernel for Atan2 {
        const NAME: &'static str = "atan2";
        fn eval<F: Float>(a: F, b: F, _: F) -> F {
            atan2(a, b)
        }
    }
    struct Acos;
    impl Kernel for Acos {
        const NAME: &'static str = "acos";
        fn eval<F: Float>(a: F, _: F, _: F) -> F {
            acos(a)
        }
    }

    const N: usize = 100_000;

    /// Branch points and range limits of the functions, whose neighbours the
    /// inputs include.
    const EDGES: [f32; 16] = [
        SIN_COS_MAX,
        -SIN_COS_MAX,
        88.722_84,
        88.0,
        100.0,
        -87.336_55,
        -103.972_08,
        -104.0,
        f32::MIN_POSITIVE,
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::SQRT_2,
        0.927_734_4,
        -0.927_734_4,
        3.919_206_6,
        2.414_213_6,
        0.414_213_57,
    ];

    /// Pairs for atan2: every pair of a few specials, then random pairs:
    /// points on circles of log-uniform radius, any bit patterns, and one
    /// coordinate zero.
    fn atan2_args(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let few = [0.0, -0.0, 1.0, -1.0, 1e-40, -3.5, 1e30, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MAX];
        let mut v: Vec<[f32; 3]> = few.iter().flat_map(|&y| few.iter().map(move |&x| [y, x, 0.0])).collect();
        let mut rng = Rng::new(seed);
        while v.len() < n {
            let p = match rng.next_u64() % 4 {
                0 | 1 => {
                    let phi = (rng.unit() * 2.0 - 1.0) * std::f64::consts::PI;
                    let r = rng.log_uniform().abs() as f64;
                    [(r * phi.sin()) as f32, (r * phi.cos()) as f32, 0.0]
                }
                2 => [rng.bits(), rng.bits(), 0.0],
                _ => [rng.uniform(-2.0, 2.0), if rng.next_u64() & 1 == 0 { 0.0 } else { -0.0 }, 0.0],
            };
            v.push(if rng.next_u64() & 7 == 0 { [p[1], p[0], 0.0] } else { p });
        }
        v
    }

    /// (a) Every lane of every SIMD instance equals the scalar result, bit
    /// for bit (NaN = NaN), over 10⁵ inputs per function.
    #[test]
    fn lanes_equal_scalar() {
        let pi = std::f32::consts::PI;
        let mut ran = Vec::new();
        ran.push(check_kernel::<Sin>(&unary_args(N, 1, -4.0 * pi, 4.0 * pi, &EDGES)));
        ran.push(check_kernel::<Cos>(&unary_args(N, 2, -4.0 * pi, 4.0 * pi, &EDGES)));
        let mut sc = unary_args(N, 3, -4.0 * pi, 4.0 * pi, &EDGES);
        for (i, a) in sc.iter_mut().enumerate() {
            a[1] = (i % 2) as f32;
        }
        ran.push(check_kernel::<SinCos>(&sc));
        ran.push(check_kernel::<Exp>(&unary_args(N, 4, -110.0, 95.0, &EDGES)));
        ran.push(check_kernel::<Ln>(&unary_args(N, 5, 0.0, 4.0, &EDGES)));
        ran.push(check_kernel::<Erf>(&unary_args(N, 6, -5.0, 5.0, &EDGES)));
        ran.push(check_kernel::<Erfinv>(&unary_args(N, 10, -1.0, 1.0, &EDGES)));
        ran.push(check_kernel::<Atan>(&unary_args(N, 7, -20.0, 20.0, &EDGES)));
        ran.push(check_kernel::<Atan2>(&atan2_args(N, 8)));
        ran.push(check_kernel::<Acos>(&unary_args(N, 9, -1.1, 1.1, &EDGES)));
        println!("instances tested besides f32: {:?}", ran[0]);
        assert!(ran.iter().all(|r| *r == ran[0]));
    }

    /// sin_cos is (sin, cos); sin, erf and atan are odd and cos even, bit
    /// for bit (which the survey relies on); the scalar atan, atan2 and acos
    /// are math::fast's, bit for bit.
    #[test]
    fn scalar_equals_references() {
        for a in unary_args(N, 11, -20.0, 20.0, &EDGES) {
            let x = a[0];
            let (s, c) = sin_cos(x);
            assert!(same(s, sin(x), false) && same(c, cos(x), false), "sin_cos({x:e})");
            assert!(same(sin(-x), -sin(x), true) && same(cos(-x), cos(x), true), "sin/cos(-{x:e})");
            assert!(same(erf(-x), -erf(x), true) && same(atan(-x), -atan(x), true), "erf/atan(-{x:e})");
            assert!(same(atan(x), fast::atan(x), false), "atan({x:e}): {} vs {}", atan(x), fast::atan(x));
            assert!(same(acos(x), fast::acos(x), false), "acos({x:e}): {} vs {}", acos(x), fast::acos(x));
        }
        for a in atan2_args(N, 12) {
            let (y, x) = (a[0], a[1]);
            assert!(same(atan2(y, x), fast::atan2(y, x), false), "atan2({y:e}, {x:e})");
        }
    }

    /// erfinv inverts erf: the residual |erf(erfinv y) − y| (erf in f64)
    /// stays below 4e-7 over (−1, 1), and the ends are ±∞.
    #[test]
    fn erfinv_inverts_erf() {
        let mut rng = Rng::new(21);
        let mut worst: f64 = 0.0;
        for i in 0..200_000 {
            let y = if i % 2 == 0 { rng.uniform(-1.0, 1.0) } else { 1.0 - (rng.log_uniform().abs() as f32).min(1.0) };
            if y <= -1.0 || y >= 1.0 {
                continue;
            }
            let x = erfinv(y);
            assert!(x.is_finite(), "erfinv({y:e}) = {x}");
            worst = worst.max((erf_ref(x as f64) - y as f64).abs());
        }
        assert!(worst < 4e-7, "largest residual {worst:e}");
        assert_eq!(erfinv(1.0f32), f32::INFINITY);
        assert_eq!(erfinv(-1.0f32), f32::NEG_INFINITY);
        assert!(same(erfinv(-0.3f32), -erfinv(0.3f32), true));
    }

    /// The largest ulp error of `f` against `reference` over `xs`, and where.
    fn worst(xs: impl Iterator<Item = f32>, f: impl Fn(f32) -> f32, reference: impl Fn(f64) -> f64) -> (f64, f32) {
        let mut w = (0.0, 0.0);
        for x in xs {
            let e = ulp_error(f(x), reference(x as f64));
            if e > w.0 || e.is_nan() {
                w = (e, x);
            }
        }
        w
    }

    /// Inputs for the accuracy tests: `n` uniform in [lo, hi], `n` with
    /// log-uniform magnitude in [2^lo_exp, max(|lo|, |hi|)] and the sign
    /// of a random point of [lo, hi], and the neighbours of `points`.
    fn domain(n: usize, seed: u64, lo: f32, hi: f32, lo_exp: i32, points: &[f32]) -> Vec<f32> {
        let mut rng = Rng::new(seed);
        let top = (lo.abs().max(hi.abs()) as f64).log2();
        let mut v = Vec::with_capacity(2 * n + 33 * points.len());
        for _ in 0..n {
            v.push(rng.uniform(lo, hi));
            let m = (2.0f64).powf(lo_exp as f64 + (top - lo_exp as f64) * rng.unit()) as f32;
            let x = if rng.uniform(lo, hi) < 0.0 { -m } else { m };
            if (lo..=hi).contains(&x) {
                v.push(x);
            }
        }
        for &p in points {
            for k in -16..=16 {
                let x = ulps_away(p, k);
                if (lo..=hi).contains(&x) {
                    v.push(x);
                }
            }
        }
        v
    }

    /// Multiples of π/2 up to `max`, the worst places for sin and cos.
    fn quadrant_points(max: f32, count: usize) -> Vec<f32> {
        let kmax = (max as f64 / std::f64::consts::FRAC_PI_2) as u64;
        let mut rng = Rng::new(99);
        let mut v: Vec<f32> = (0..=64).map(|k| (k as f64 * std::f64::consts::FRAC_PI_2) as f32).collect();
        v.extend((0..count).map(|_| ((rng.next_u64() % kmax) as f64 * std::f64::consts::FRAC_PI_2) as f32));
        v.iter().flat_map(|&x| [x, -x]).collect()
    }

    /// The documented error bounds, in ulps.
    const SIN_ULP: f64 = 1.57;
    const COS_ULP: f64 = 1.59;
    const EXP_ULP: f64 = 1.02;
    const LN_ULP: f64 = 0.83;
    const ERF_ULP: f64 = 1.03;
    const ATAN_ULP: f64 = 2.84;
    const ATAN2_ULP: f64 = 3.19;
    const ACOS_ULP: f64 = 3.73;

    /// (b) Accuracy against f64 over each function's domain, within the
    /// documented bounds; the special values.
    #[test]
    fn accuracy() {
        let n = 1 << 19;
        let mut results = Vec::new();
        let mut check = |name: &str, (e, x): (f64, f32), bound: f64| results.push((name.to_string(), e, x, bound));
        let qp = quadrant_points(SIN_COS_MAX, 20_000);
        let mut trig = domain(n, 21, -10.0, 10.0, -30, &qp);
        trig.extend(domain(n / 4, 22, -SIN_COS_MAX, SIN_COS_MAX, -10, &EDGES));
        check("sin", worst(trig.iter().copied(), sin, f64::sin), SIN_ULP);
        check("cos", worst(trig.iter().copied(), cos, f64::cos), COS_ULP);
        let ex = domain(n, 23, -104.0, 89.0, -30, &EDGES);
        check("exp", worst(ex.into_iter(), exp, f64::exp), EXP_ULP);
        let mut lx = domain(n, 24, 0.0, 4.0, -149, &EDGES);
        let mut rng = Rng::new(25);
        lx.extend((0..n).map(|_| rng.bits().abs()).filter(|x| x.is_finite()));
        lx.extend((0..n).map(|_| 1.0 + rng.log_uniform().clamp(-0.25, 0.25)));
        check("ln", worst(lx.into_iter(), ln, f64::ln), LN_ULP);
        let mut erx = domain(n, 26, -6.0, 6.0, -40, &EDGES);
        erx.extend((0..n).map(|_| rng.bits()));
        check("erf", worst(erx.into_iter(), erf, erf_ref), ERF_ULP);
        let mut ax = domain(n, 27, -20.0, 20.0, -40, &EDGES);
        ax.extend((0..n).map(|_| rng.bits()));
        check("atan", worst(ax.into_iter(), atan, f64::atan), ATAN_ULP);
        let pairs: Vec<[f32; 3]> = atan2_args(4 * n, 28)
            .into_iter()
            .filter(|a| a[1] != 0.0 && !(a[0].is_infinite() && a[1].is_infinite()))
            .collect();
        let mut w2 = (0.0, 0.0, 0.0);
        for a in &pairs {
            let e = ulp_error(atan2(a[0], a[1]), (a[0] as f64).atan2(a[1] as f64));
            if e > w2.0 {
                w2 = (e, a[0], a[1]);
            }
        }
        check(&format!("atan2 (x = {:e}), at y", w2.2), (w2.0, w2.1), ATAN2_ULP);
        let mut cx = domain(n, 29, -1.0, 1.0, -40, &[1.0, -1.0, 0.5, -0.5]);
        cx.extend((0..n).map(|_| 1.0 - rng.log_uniform().abs().min(1.0)));
        cx.extend((0..n).map(|_| -1.0 + rng.log_uniform().abs().min(1.0)));
        check("acos", worst(cx.into_iter(), acos, f64::acos), ACOS_ULP);
        for (name, e, x, bound) in &results {
            println!("{name}: {e:.3} ulp at {x:e} (bound {bound})");
        }
        for (name, e, x, bound) in &results {
            assert!(e <= bound, "{name}: {e} ulp at {x:e} ({:#010x}), bound {bound}", x.to_bits());
        }

        // Special values.
        assert!(same(sin(-0.0), -0.0, false) && same(sin(0.0), 0.0, false));
        assert_eq!((cos(0.0), cos(-0.0)), (1.0, 1.0));
        for x in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, ulps_away(SIN_COS_MAX, 1), 1e30] {
            assert!(sin(x).is_nan() && cos(x).is_nan(), "sin/cos({x:e})");
        }
        assert!(!sin(SIN_COS_MAX).is_nan());
        assert_eq!((exp(0.0), exp(-0.0), exp(f32::INFINITY), exp(f32::NEG_INFINITY)), (1.0, 1.0, f32::INFINITY, 0.0));
        assert_eq!((exp(88.8), exp(-110.0)), (f32::INFINITY, 0.0));
        assert!(exp(f32::NAN).is_nan());
        assert_eq!(
            (ln(1.0), ln(0.0), ln(-0.0), ln(f32::INFINITY)),
            (0.0, f32::NEG_INFINITY, f32::NEG_INFINITY, f32::INFINITY)
        );
        assert!(ln(-1.0).is_nan() && ln(f32::NEG_INFINITY).is_nan() && ln(f32::NAN).is_nan() && ln(-1e-45).is_nan());
        assert_eq!(ln(f32::from_bits(1)), (-149.0 * std::f64::consts::LN_2) as f32);
        assert_eq!((erf(f32::INFINITY), erf(f32::NEG_INFINITY), erf(10.0), erf(-10.0)), (1.0, -1.0, 1.0, -1.0));
        assert!(same(erf(-0.0), -0.0, false) && erf(f32::NAN).is_nan());
        assert_eq!((atan(f32::INFINITY), atan(f32::NEG_INFINITY)), (FRAC_PI_2, -FRAC_PI_2));
        assert!(same(atan(-0.0), -0.0, false) && atan(f32::NAN).is_nan());
        assert_eq!((atan2(0.0, 0.0), atan2(1.0, 0.0), atan2(-1.0, -0.0)), (0.0, FRAC_PI_2, -FRAC_PI_2));
        assert_eq!((atan2(0.0, -1.0), atan2(-0.0, -1.0)), (PI, -PI));
        assert!(atan2(f32::INFINITY, f32::INFINITY).is_nan() && atan2(f32::NAN, 1.0).is_nan());
        assert_eq!((acos(1.0), acos(-1.0), acos(2.0), acos(-2.0), acos(0.0)), (0.0, PI, 0.0, PI, FRAC_PI_2));
        assert!(acos(f32::NAN).is_nan());
    }

    /// The largest ulp error of `f` over every `stride`-th f32 from `lo` to
    /// `hi` (finite, `lo` ≤ `hi`, 0 ≤ `hi`), and where, and where; on all threads.
    fn sweep(
        lo: f32,
        hi: f32,
        stride: u32,
        f: impl Fn(f32) -> f32 + Sync,
        reference: impl Fn(f64) -> f64 + Sync,
    ) -> (f64, f32) {
        use rayon::prelude::*;
        let probe = |x: f32| (ulp_error(f(x), reference(x as f64)), x);
        let better = |a: (f64, f32), b: (f64, f32)| if b.0 > a.0 { b } else { a };
        // Bit patterns from `a` up to `b` (the same sign), in chunks.
        let run = |a: u32, b: u32| {
            const CHUNK: u32 = 1 << 22;
            let chunks = (b - a) / CHUNK + 1;
            (0..chunks)
                .into_par_iter()
                .map(|k| {
                    let start = a + k * CHUNK;
                    let end = b.min(start + CHUNK - 1);
                    let first = start + (stride - (start - a) % stride) % stride;
                    (first..=end)
                        .step_by(stride as usize)
                        .fold(probe(f32::from_bits(end)), |w, i| better(w, probe(f32::from_bits(i))))
                })
                .reduce(|| (0.0, lo), better)
        };
        assert!(lo <= hi && hi >= 0.0);
        let neg = if lo < 0.0 { run((-0.0f32).to_bits(), lo.to_bits()) } else { (0.0, lo) };
        better(neg, run(lo.max(0.0).to_bits(), hi.to_bits()))
    }

    /// The error survey behind the documented bounds: every 16th f32 of
    /// each domain (every one with `PENUMBRA_SURVEY_STRIDE=1`), positive
    /// arguments only for the odd and even functions (their negative side
    /// mirrors it bit for bit), and 10⁷ random atan2 pairs. About 40 s (stride
    /// 16) or 10 min (stride 1) on one core.
    #[test]
    #[ignore = "a survey of about 10⁹ evaluations; run by hand when a function changes"]
    fn survey() {
        let stride = std::env::var("PENUMBRA_SURVEY_STRIDE").ok().and_then(|s| s.parse().ok()).unwrap_or(16);
        let rows = [
            ("sin", sweep(0.0, SIN_COS_MAX, stride, sin, f64::sin), SIN_ULP),
            ("cos", sweep(0.0, SIN_COS_MAX, stride, cos, f64::cos), COS_ULP),
            ("exp", sweep(-104.0, 89.0, stride, exp, f64::exp), EXP_ULP),
            ("ln", sweep(f32::from_bits(1), f32::MAX, stride, ln, f64::ln), LN_ULP),
            ("erf", sweep(0.0, f32::MAX, stride, erf, erf_ref), ERF_ULP),
            ("atan", sweep(0.0, f32::MAX, stride, atan, f64::atan), ATAN_ULP),
            ("acos", sweep(-1.0, 1.0, stride, acos, f64::acos), ACOS_ULP),
        ];
        let mut w2 = (0.0, 0.0);
        for a in atan2_args(10_000_000, 31) {
            if a[1] != 0.0 && !(a[0].is_infinite() && a[1].is_infinite()) {
                let e = ulp_error(atan2(a[0], a[1]), (a[0] as f64).atan2(a[1] as f64));
                if e > w2.0 {
                    w2 = (e, a[0]);
                }
            }
        }
        for (name, (e, x), bound) in rows.iter().chain([("atan2", w2, ATAN2_ULP)].iter()) {
            println!("{name}: {e:.3} ulp at {x:e} (bound {bound}), stride {stride}");
            assert!(e <= bound, "{name}: {e} ulp at {x:e}");
        }
    }
}
