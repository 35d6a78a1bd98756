//! Counter-based hashing: every random number is a pure function of
//! (seed, pixel, sample index, dimension), so images do not depend on the
//! thread count or the order in which tiles are rendered.

/// A 64-bit finaliser with good avalanche (the `splitmix64` output function).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// Hashes a sequence of words into one 64-bit key.
#[inline]
pub fn hash_words(words: &[u64]) -> u64 {
    let mut h = 0x9e3779b97f4a7c15u64;
    for &w in words {
        h = mix64(h ^ w.wrapping_add(0x9e3779b97f4a7c15));
    }
    h
}

/// Maps the top 24 bits of a hash to a float in [0, 1). Converted from
/// `i32` (exact: the value is below 2²⁴): x86 has no one-instruction
/// conversion from `u64` before AVX-512.
#[inline]
pub fn to_unit_f32(h: u64) -> f32 {
    ((h >> 40) as i32) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// Kensler's hashed permutation ("Correlated Multi-Jittered Sampling", 2013):
/// maps `i` in [0, n) to a pseudo-random position in [0, n), bijectively.
pub fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    if n <= 1 {
        return 0;
    }
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= seed;
        i = i.wrapping_mul(0xe170893d);
        i ^= seed >> 16;
        i ^= (i & w) >> 4;
        i ^= seed >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= seed >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | seed >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    (i.wrapping_add(seed)) % n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_is_a_bijection() {
        for n in [1u32, 2, 3, 7, 16, 17, 100] {
            for seed in [0u32, 1, 0xdeadbeef] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let j = permute(i, n, seed) as usize;
                    assert!(!seen[j]);
                    seen[j] = true;
                }
            }
        }
    }

    #[test]
    fn unit_floats_are_uniform() {
        // Mean and variance of 100k hashed uniforms: mean 1/2 ± 4σ, σ = sqrt(1/12/n).
        let n = 100_000;
        let xs: Vec<f32> = (0..n).map(|i| to_unit_f32(hash_words(&[7, i]))).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 4.0 * (1.0 / 12.0 / n as f64).sqrt());
    }
}
