//! Test support for generic lane code: runs a [`Kernel`] on every SIMD
//! instance compiled in and compares each lane with the scalar instance bit
//! for bit; fixed-seed inputs with the edge cases; errors in ulps against
//! f64 references.

use super::Float;

/// Lane code under test: up to three float arguments, one float result
/// (integer results as their bits through [`Float::from_bits`], masks as
/// 1.0 / 0.0 through [`Float::select`]).
pub(crate) trait Kernel {
    /// Name in failure messages.
    const NAME: &'static str;
    /// Whether NaN results of different payloads count as equal (float
    /// results); integer results must set it false.
    const NAN_EQUAL: bool = true;
    /// The kernel on `F`; arguments it does not use are ignored.
    fn eval<F: Float>(a: F, b: F, c: F) -> F;
}

/// Whether `got` is bitwise `want`, or both are NaN where `nan_equal`.
pub(crate) fn same(got: f32, want: f32, nan_equal: bool) -> bool {
    got.to_bits() == want.to_bits() || (nan_equal && got.is_nan() && want.is_nan())
}

/// Runs `K` on instance `F` over `args`, `F::WIDTH` at a time (the last
/// group padded with the first arguments), from `offset` so that each input
/// also lands in other lanes, and compares every lane with the scalar `K`.
fn compare<K: Kernel, F: Float>(args: &[[f32; 3]], offset: usize) -> usize {
    let w = F::WIDTH;
    let n = args.len();
    let at = |i: usize| args[(i + offset) % n];
    let mut checked = 0;
    for start in (0..n).step_by(w) {
        let (mut a, mut b, mut c) = (F::Array::default(), F::Array::default(), F::Array::default());
        for l in 0..w {
            let v = at(start + l);
            (a.as_mut()[l], b.as_mut()[l], c.as_mut()[l]) = (v[0], v[1], v[2]);
        }
        let got = K::eval(F::from_array(a), F::from_array(b), F::from_array(c)).to_array();
        for l in 0..w {
            let v = at(start + l);
            let want = K::eval::<f32>(v[0], v[1], v[2]);
            let g = got.as_ref()[l];
            assert!(
                same(g, want, K::NAN_EQUAL),
                "{} on {}, lane {l}: args {:?} (bits {:08x?}): got {g:e} ({:#010x}), scalar {want:e} ({:#010x})",
                K::NAME,
                F::NAME,
                v,
                v.map(f32::to_bits),
                g.to_bits(),
                want.to_bits()
            );
            checked += 1;
        }
    }
    checked
}

/// Something generic to run on each instance.
pub(crate) trait Visit {
    /// Runs on instance `F`.
    fn visit<F: Float>(&mut self);
}

/// Runs `v` on every SIMD instance compiled in and returns their names.
///
/// # Panics
/// If the running CPU has the features of an instance that was not
/// compiled in (the build lacks `target-cpu=native`), so that the checks
/// cannot pass by testing nothing.
pub(crate) fn each_simd<V: Visit>(v: &mut V) -> Vec<&'static str> {
    #[allow(unused_mut)] // empty where no SIMD instance is compiled in
    let mut names = Vec::new();
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    {
        v.visit::<super::F32x8>();
        names.push(<super::F32x8 as Float>::NAME);
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    {
        v.visit::<super::F32x16>();
        names.push(<super::F32x16 as Float>::NAME);
    }
    #[cfg(target_arch = "x86_64")]
    {
        let has = |f: &str| names.contains(&f);
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            assert!(
                has("F32x8"),
                "this CPU has AVX2 and FMA but F32x8 is not compiled in: build with target-cpu=native"
            );
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            assert!(has("F32x16"), "this CPU has AVX-512F but F32x16 is not compiled in: build with target-cpu=native");
        }
    }
    let _ = v;
    names
}

struct Compare<'a, K> {
    args: &'a [[f32; 3]],
    checked: usize,
    kernel: std::marker::PhantomData<K>,
}

impl<K: Kernel> Visit for Compare<'_, K> {
    fn visit<F: Float>(&mut self) {
        for offset in [0, 3] {
            self.checked += compare::<K, F>(self.args, offset);
        }
    }
}

/// Checks `K` on every SIMD instance against the scalar one, lane by lane,
/// over `args`; prints and returns the instances tested.
pub(crate) fn check_kernel<K: Kernel>(args: &[[f32; 3]]) -> Vec<&'static str> {
    assert!(!args.is_empty());
    let mut c = Compare::<K> { args, checked: 0, kernel: std::marker::PhantomData };
    let names = each_simd(&mut c);
    println!("{}: {} lanes bitwise equal to f32 on {:?}", K::NAME, c.checked, names);
    names
}

/// SplitMix64: a fixed-seed generator for test inputs.
pub(crate) struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub(crate) fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1), 53 bits.
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform in [lo, hi] as f32.
    pub(crate) fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        (lo as f64 + (hi as f64 - lo as f64) * self.unit()).clamp(lo as f64, hi as f64) as f32
    }
    /// Any f32 bit pattern (NaNs and infinities included).
    pub(crate) fn bits(&mut self) -> f32 {
        f32::from_bits(self.next_u64() as u32)
    }
    /// A magnitude log-uniform in [2⁻¹⁴⁹, 2¹²⁸) with a random sign.
    pub(crate) fn log_uniform(&mut self) -> f32 {
        let m = (2.0f64).powf(-149.0 + 277.0 * self.unit()) as f32;
        if self.next_u64() & 1 == 0 {
            m
        } else {
            -m
        }
    }
}

/// `x` moved by `k` units in the last place (towards +∞ for k > 0), −0
/// and +0 one apart; infinities and NaNs unchanged.
pub(crate) fn ulps_away(x: f32, k: i32) -> f32 {
    if !x.is_finite() {
        return x;
    }
    // The floats' order as integers: +0 → 0, −0 → −1, …
    let b = x.to_bits();
    let key = if b >> 31 == 1 { -((b & 0x7fff_ffff) as i64) - 1 } else { b as i64 };
    let key = (key + k as i64).clamp(-0x7f80_0001, 0x7f80_0000);
    f32::from_bits(if key < 0 { (-key - 1) as u32 | 0x8000_0000 } else { key as u32 })
}

/// Values every function meets: zeros, subnormals, ±1 and their
/// neighbours, powers of two, multiples of π/4 and their neighbours,
/// rounding ties, the i32 conversion range, huge values, infinities and
/// NaNs (quiet, with payloads, signalling, negative), plus `extra` points
/// and their neighbours.
pub(crate) fn specials(extra: &[f32]) -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        1e-30,
        -1e-30,
        1e-7,
        0.5,
        1.5,
        2.5,
        -2.5,
        1e7,
        16_777_217.0,
        2_147_483_648.0,
        -2_147_483_648.0,
        2_147_483_520.0,
        1e20,
        -1e20,
        1e30,
        f32::MAX,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7fc0_0001),
        f32::from_bits(0xffc1_2345),
        f32::from_bits(0x7f80_0001),
        f32::from_bits(0xff80_0001),
    ];
    for e in -24..=24 {
        let p = (2.0f32).powi(e);
        v.extend([p, -p]);
    }
    let mut centres: Vec<f32> = vec![1.0, -1.0];
    for k in -16..=16 {
        centres.push(k as f32 * std::f32::consts::FRAC_PI_4);
    }
    for k in [100, 1000, 10_000, 100_000, 1_000_000] {
        centres.extend([k as f32 * std::f32::consts::FRAC_PI_2, -(k as f32) * std::f32::consts::FRAC_PI_2]);
    }
    centres.extend_from_slice(extra);
    for &x in &centres {
        for k in -3..=3 {
            v.push(ulps_away(x, k));
        }
    }
    v
}

/// `n` arguments for a one-argument function: the [`specials`] (with
/// `extra`), then random values: half uniform in [lo, hi], a sixth each any
/// bit pattern, log-uniform magnitude, and within 8 ulps of a special.
pub(crate) fn unary_args(n: usize, seed: u64, lo: f32, hi: f32, extra: &[f32]) -> Vec<[f32; 3]> {
    let sp = specials(extra);
    let mut rng = Rng::new(seed);
    let mut v: Vec<f32> = sp.clone();
    while v.len() < n {
        let x = match rng.next_u64() % 6 {
            0..=2 => rng.uniform(lo, hi),
            3 => rng.bits(),
            4 => rng.log_uniform(),
            _ => ulps_away(sp[(rng.next_u64() % sp.len() as u64) as usize], (rng.next_u64() % 17) as i32 - 8),
        };
        v.push(x);
    }
    v.into_iter().map(|x| [x, 0.0, 0.0]).collect()
}

/// Error of `got` against the exact `want` in ulps of the f32 nearest
/// `want` (for subnormal results, units of 2⁻¹⁴⁹); 0 for matching NaNs and
/// infinities (an f64 `want` beyond f32's range counts as the infinity it
/// rounds to), +∞ for a NaN or infinity where the other is not.
pub(crate) fn ulp_error(got: f32, want: f64) -> f64 {
    let w32 = want as f32;
    if got.is_nan() || want.is_nan() {
        return if got.is_nan() && want.is_nan() { 0.0 } else { f64::INFINITY };
    }
    if got.is_infinite() || w32.is_infinite() {
        return if got == w32 { 0.0 } else { f64::INFINITY };
    }
    let mag = want.abs().max(f32::MIN_POSITIVE as f64);
    // 2^(exponent of mag − 23), the spacing of f32s at mag.
    let exp = ((mag.to_bits() >> 52) as i32) - 1023;
    let ulp = (2.0f64).powi(exp - 23);
    (got as f64 - want).abs() / ulp
}
