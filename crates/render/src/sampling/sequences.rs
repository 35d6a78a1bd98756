//! The point constructions behind Mitsuba 3.9.1's `multijitter`,
//! `orthogonal` and `ldsampler` (src/samplers/*.cpp, include/mitsuba/core/qmc.h),
//! as pure functions of (sample index, seeds, jitter). Permutations are
//! Kensler's hashed permutation ([`permute`]).

use super::rng::{mix64, permute};
use glam::Vec2;

use crate::math::ONE_MINUS_EPS;

/// Correlated multi-jittered 1D sample: sample `i` of `n`, strata shuffled by
/// `seed`, offset `jitter` in [0, 1) inside its stratum.
#[inline]
pub fn multijitter_1d(i: u32, n: u32, seed: u32, jitter: f32) -> f32 {
    let p = permute(i, n, seed.wrapping_mul(0x45fbe943));
    ((p as f32 + jitter) / n as f32).min(ONE_MINUS_EPS)
}

/// Correlated multi-jittered 2D sample (Kensler 2013, as Mitsuba's
/// `multijitter`): the n = res_x · res_y samples fill every cell of the
/// res_x × res_y grid once, and their sub-cell offsets form Latin hypercubes
/// in x and in y (one sample per column of width 1/n and per row of height 1/n).
#[inline]
pub fn multijitter_2d(i: u32, res: (u32, u32), seed: u32, jitter: Vec2) -> Vec2 {
    let (rx, ry) = res;
    let s = permute(i, rx * ry, seed.wrapping_mul(0x51633e2d));
    let (x, y) = (s % rx, s / rx);
    let sx = permute(x, rx, seed.wrapping_mul(0x68bc21eb));
    let sy = permute(y, ry, seed.wrapping_mul(0x02e5be93));
    Vec2::new(
        ((x as f32 + (sy as f32 + jitter.x) / ry as f32) / rx as f32).min(ONE_MINUS_EPS),
        ((y as f32 + (sx as f32 + jitter.y) / rx as f32) / ry as f32).min(ONE_MINUS_EPS),
    )
}

/// The smallest prime r ≥ 2 with r² ≥ spp (Mitsuba's `orthogonal` resolution).
pub fn orthogonal_resolution(spp: u32) -> u32 {
    #[allow(clippy::manual_is_multiple_of)] // `is_multiple_of` is newer than the crates' rust-version
    let is_prime = |x: u32| (2..=x / 2).all(|i| x % i != 0);
    let mut r = 2u32;
    while (r as u64 * r as u64) < spp as u64 || !is_prime(r) {
        r += 1;
    }
    r
}

/// Column `j` (0 ≤ j ≤ r) of Bose's orthogonal array OA(r², r + 1, r, 2) for
/// sample `i` of r², with Mitsuba's multi-jitter flavour: the column value
/// picks one of r strata and the partner column's value one of r
/// sub-strata, both shuffled. Any two columns are stratified jointly on the
/// r × r grid, and each column alone is a Latin hypercube of r² strata.
/// `key` seeds the sample order (shared by all columns) and the shuffles.
#[inline]
pub fn bose(i: u32, j: u32, r: u32, key: u64, jitter: f32) -> f32 {
    let n = r * r;
    let i = permute(i % n, n, key as u32);
    let (a0, a1) = (i / r, i % r);
    let k = if j % 2 == 1 { j - 1 } else { j + 1 };
    let col = |c: u32| match c {
        0 => a0,
        1 => a1,
        _ => (a0 + (c - 1) * a1) % r,
    };
    let (aij, aik) = match j {
        0 => (a0, a1),
        1 => (a1, a0),
        _ => (col(j), col(k)),
    };
    let h = mix64(key ^ (j as u64 + 1).wrapping_mul(0x9e3779b97f4a7c15));
    let stratum = permute(aij, r, h as u32);
    let sub = permute(aik, r, (h >> 32) as u32);
    ((stratum as f32 + (sub as f32 + jitter) / r as f32) / r as f32).min(ONE_MINUS_EPS)
}

/// Van der Corput radical inverse in base 2 of `index`, XOR-scrambled.
#[inline]
pub fn radical_inverse_2(index: u32, scramble: u32) -> f32 {
    (((index.reverse_bits() ^ scramble) >> 8) as f32 * (1.0 / (1u32 << 24) as f32)).min(ONE_MINUS_EPS)
}

/// Sobol's second dimension (base 2) of `index`, XOR-scrambled.
#[inline]
pub fn sobol_2(mut index: u32, mut scramble: u32) -> f32 {
    let mut v = 1u32 << 31;
    while index != 0 {
        if index & 1 == 1 {
            scramble ^= v;
        }
        index >>= 1;
        v ^= v >> 1;
    }
    ((scramble >> 8) as f32 * (1.0 / (1u32 << 24) as f32)).min(ONE_MINUS_EPS)
}

/// `sobol_burley::sample_4d(index, 0, seed)`, bitwise, without its loop
/// over the index's bits. Sobol' points are XORs of direction vectors, one
/// per set bit of the (shuffled) index, and the crate uses the top 16 bits,
/// so the XOR over each byte of them comes from a 256-entry table built
/// once from the crate's own `sobol_int4_rev` (its set bits are disjoint, so
/// the XORs combine). The crate's loop visits about eight set bits with a
/// bit scan each, which was two fifths of a Cornell-box render with
/// `--sampler sobol`. The shuffle and Owen scrambles are the crate's
/// (`parts`), with its constants; a test compares every index with the crate.
#[inline]
pub fn sobol_4d_first_set(index: u32, seed: u32) -> [f32; 4] {
    use sobol_burley::parts::{hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, Int4};
    debug_assert!(index < 1 << 16);
    let shuffled = owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c68e4a));
    let t = sobol_byte_tables();
    let sobol = Int4::from(t[0][(shuffled >> 24) as usize]) ^ Int4::from(t[1][(shuffled >> 16 & 0xff) as usize]);
    // The crate's scramble for dimension set 0: seed ^ 0 ^ its constants.
    let seed = seed.wrapping_mul(0x9c8f2d3b);
    let scramble = Int4::from([seed ^ 0x912f69ba, seed ^ 0x174f18ab, seed ^ 0x691e72ca, seed ^ 0xb40cc1b8]);
    owen_scramble_int4_rev(sobol, hash_int4(scramble)).reverse_bits().to_f32_norm()
}

/// For each of the top two bytes of a bit-reversed index, the XOR of the
/// first dimension set's direction vectors over each byte value (8 KiB).
fn sobol_byte_tables() -> &'static [[[u32; 4]; 256]; 2] {
    static TABLES: std::sync::OnceLock<Box<[[[u32; 4]; 256]; 2]>> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = Box::new([[[0u32; 4]; 256]; 2]);
        for b in 0..256u32 {
            t[0][b as usize] = sobol_burley::parts::sobol_int4_rev(b << 24, 0).into();
            t[1][b as usize] = sobol_burley::parts::sobol_int4_rev(b << 16, 0).into();
        }
        t
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_tables_give_the_crates_points() {
        for seed in [0, 1, 0x9e3779b9, u32::MAX] {
            for index in 0..1u32 << 16 {
                let (a, b) = (sobol_4d_first_set(index, seed), sobol_burley::sample_4d(index, 0, seed));
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "index {index}, seed {seed}");
            }
        }
    }

    #[test]
    fn orthogonal_resolutions_are_mitsubas() {
        // Mitsuba 3.9.1: mi.load_dict({'type': 'orthogonal', 'sample_count': n}).sample_count()
        for (spp, r) in [(1, 2), (4, 2), (5, 3), (16, 5), (25, 5), (26, 7), (64, 11)] {
            assert_eq!(orthogonal_resolution(spp), r, "{spp}");
        }
    }

    #[test]
    fn zero_two_sequence_is_stratified_in_every_elementary_interval() {
        // The first 2^m points of (radical inverse, Sobol 2) put one point in
        // every elementary interval of area 2^-m, for any XOR scramble.
        for m in 0..=8u32 {
            let n = 1u32 << m;
            for (sx, sy) in [(0u32, 0u32), (0xdeadbeef, 0x12345678)] {
                for a in 0..=m {
                    let (nx, ny) = (1u32 << a, 1u32 << (m - a));
                    let mut hit = vec![false; n as usize];
                    for i in 0..n {
                        let (x, y) = (radical_inverse_2(i, sx), sobol_2(i, sy));
                        let c = (y * ny as f32) as u32 * nx + (x * nx as f32) as u32;
                        assert!(!hit[c as usize], "m {m} a {a} i {i}");
                        hit[c as usize] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn bose_columns_are_pairwise_stratified() {
        for r in [2u32, 3, 5, 7] {
            let n = r * r;
            for j in 0..=r {
                for k in 0..=r {
                    if j == k {
                        continue;
                    }
                    let mut cells = vec![0; n as usize];
                    let mut fine = vec![0; n as usize];
                    for i in 0..n {
                        let (x, y) = (bose(i, j, r, 77, 0.5), bose(i, k, r, 77, 0.5));
                        cells[((y * r as f32) as u32 * r + (x * r as f32) as u32) as usize] += 1;
                        fine[(x * n as f32) as usize] += 1;
                    }
                    assert!(cells.iter().all(|&c| c == 1), "r {r} columns {j}, {k}");
                    assert!(fine.iter().all(|&c| c == 1), "r {r} column {j} is not a Latin hypercube");
                }
            }
        }
    }

    #[test]
    fn multijitter_fills_cells_and_rows() {
        for (rx, ry) in [(4u32, 4u32), (5, 4), (3, 2)] {
            let n = rx * ry;
            let mut cells = vec![0; n as usize];
            let (mut cols, mut rows) = (vec![0; n as usize], vec![0; n as usize]);
            for i in 0..n {
                let p = multijitter_2d(i, (rx, ry), 12345, Vec2::splat(0.5));
                cells[((p.y * ry as f32) as u32 * rx + (p.x * rx as f32) as u32) as usize] += 1;
                cols[(p.x * n as f32) as usize] += 1;
                rows[(p.y * n as f32) as usize] += 1;
            }
            assert!(cells.iter().chain(&cols).chain(&rows).all(|&c| c == 1), "{rx}x{ry}");
        }
    }
}
