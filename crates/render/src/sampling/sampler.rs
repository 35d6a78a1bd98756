//! Samplers (Mitsuba `independent`, `stratified`, `multijitter`,
//! `orthogonal` and `ldsampler`). A sampler hands out a [`SampleStream`] per
//! (pixel, sample index); the stream's values depend only on (seed, pixel,
//! sample index, dimension).
//!
//! The stratified families follow Mitsuba 3.9.1's constructions (see
//! `sampling/sequences.rs`) with Penumbra's hashing in place of Mitsuba's
//! PCG32 and TEA seeds. Sample indices past the sampler's count start a new,
//! independently permuted set of `spp` samples (a "pass").

use super::rng::{hash_words, mix64, permute, to_unit_f32};
use super::sequences;
use crate::math::ONE_MINUS_EPS;
use glam::Vec2;

/// Which sample construction a [`Sampler`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent uniform random numbers.
    Independent,
    /// Jittered strata per dimension, sample indices shuffled per dimension
    /// (as Mitsuba's `stratified` with `jitter` = true).
    Stratified,
    /// Mitsuba `multijitter`: correlated multi-jittered sampling (Kensler
    /// 2013) on a near-square grid of `spp` = res_x · res_y cells.
    Multijitter {
        /// Random offset inside each cell (Mitsuba's `jitter`); false: cell centres.
        jitter: bool,
    },
    /// Mitsuba `orthogonal`: orthogonal-array Latin hypercubes of strength 2
    /// (Bose construction, Jarosz et al. 2019); `spp` is the square of a prime.
    Orthogonal {
        /// Random offset inside each substratum (Mitsuba's `jitter`); false: centres.
        jitter: bool,
    },
    /// Mitsuba `ldsampler`: a scrambled (0, 2)-sequence (van der Corput ×
    /// Sobol') with sample indices shuffled per dimension; `spp` is a power of
    /// two and a square.
    LowDiscrepancy,
    /// Owen-scrambled Sobol' (Burley 2020, "Practical hash-based Owen
    /// scrambling"), through the `sobol_burley` crate. Not a Mitsuba plugin:
    /// chosen with `--sampler sobol`. Dimensions are taken in sets of four,
    /// each set a differently seeded (so independently shuffled and
    /// scrambled) copy of Sobol's first four dimensions, which Burley calls
    /// padding by shuffling; a 2D draw uses one set's pair (0, 1) or (2, 3).
    /// Any sample count works; powers of two stratify best.
    Sobol,
}

impl SamplerKind {
    /// The sample count Mitsuba 3.9.1 uses when asked for `spp` samples
    /// (every kind but `independent` rounds up to what its construction needs).
    pub fn round_sample_count(self, spp: u32) -> u32 {
        let spp = spp.max(1);
        match self {
            SamplerKind::Independent | SamplerKind::Sobol => spp,
            SamplerKind::Stratified => {
                let r = (spp as f64).sqrt().ceil() as u32;
                r.saturating_mul(r)
            }
            SamplerKind::Multijitter { .. } => {
                let (rx, ry) = multijitter_resolution(spp);
                rx * ry
            }
            SamplerKind::Orthogonal { .. } => {
                let r = sequences::orthogonal_resolution(spp);
                r * r
            }
            SamplerKind::LowDiscrepancy => {
                let mut res = 2u32;
                while res * res < spp {
                    res = (res + 1).next_power_of_two();
                }
                res * res
            }
        }
    }
}

/// Mitsuba's multijitter grid: res_y = ⌊√spp⌋, res_x = ⌈spp / res_y⌉.
fn multijitter_resolution(spp: u32) -> (u32, u32) {
    let ry = ((spp as f32).sqrt() as u32).max(1);
    (spp.div_ceil(ry), ry)
}

/// A sampler plugin's settings: hands out a [`SampleStream`] per pixel sample.
#[derive(Debug, Clone, Copy)]
pub struct Sampler {
    /// The construction.
    pub kind: SamplerKind,
    /// Seed of every stream (Mitsuba's `seed`).
    pub seed: u64,
    /// Samples per pixel of the whole render (stratification needs it).
    pub spp: u32,
    /// Grid resolution: multijitter's (res_x, res_y), orthogonal's prime
    /// (r, r); unused otherwise.
    res: (u32, u32),
}

impl Sampler {
    /// A sampler of `spp` samples per pixel; stratified kinds round `spp` up
    /// as Mitsuba does (see [`SamplerKind::round_sample_count`]).
    pub fn new(kind: SamplerKind, seed: u64, spp: u32) -> Sampler {
        let spp = match kind {
            SamplerKind::Independent | SamplerKind::Stratified | SamplerKind::Sobol => spp.max(1),
            _ => kind.round_sample_count(spp),
        };
        let res = match kind {
            SamplerKind::Multijitter { .. } => multijitter_resolution(spp),
            SamplerKind::Orthogonal { .. } => {
                let r = sequences::orthogonal_resolution(spp);
                (r, r)
            }
            _ => (0, 0),
        };
        Sampler { kind, seed, spp, res }
    }

    /// The random stream of one pixel sample.
    #[inline]
    pub fn stream(&self, pixel: (u32, u32), sample_index: u32) -> SampleStream {
        self.stream_of_key(self.pixel_key(pixel), sample_index)
    }

    /// The key that every stream of `pixel` starts from, for
    /// [`Self::stream_of_key`]: a caller that makes many samples of one
    /// pixel hashes it once.
    #[inline]
    pub fn pixel_key(&self, pixel: (u32, u32)) -> u64 {
        hash_words(&[self.seed, ((pixel.1 as u64) << 32) | pixel.0 as u64])
    }

    /// [`Self::stream`] of the pixel whose [`Self::pixel_key`] is `pixel_key`.
    #[inline]
    pub fn stream_of_key(&self, pixel_key: u64, sample_index: u32) -> SampleStream {
        SampleStream {
            pixel_key,
            key: mix64(pixel_key ^ (sample_index as u64).wrapping_mul(0xd1b54a32d192ed03)),
            dim: 0,
            index: sample_index,
            sampler: *self,
            sobol_set: u32::MAX,
            sobol: [0.0; 4],
        }
    }
}

/// Random numbers for one pixel sample; `dim` counts the dimensions used.
#[derive(Debug, Clone)]
pub struct SampleStream {
    pixel_key: u64,
    key: u64,
    dim: u32,
    index: u32,
    sampler: Sampler,
    /// `Sobol`: the dimension set whose four values `sobol` holds (computed
    /// together, in SIMD, on the set's first use).
    sobol_set: u32,
    sobol: [f32; 4],
}

impl SampleStream {
    #[inline]
    fn next_hash(&mut self) -> u64 {
        self.dim += 1;
        mix64(self.key ^ (self.dim as u64).wrapping_mul(0x9e3779b97f4a7c15))
    }

    /// The dimensions drawn so far, for [`Self::rewind`].
    #[inline]
    pub fn dim(&self) -> u32 {
        self.dim
    }

    /// Back to where [`Self::dim`] was `dim`: the next draws are those that
    /// followed it (the rest of the stream's state is a cache).
    #[inline]
    pub fn rewind(&mut self, dim: u32) {
        self.dim = dim;
    }

    /// The next value in [0, 1), one dimension further.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        // The independent sampler, the default, inlined; the others call.
        if let SamplerKind::Independent = self.sampler.kind {
            return to_unit_f32(self.next_hash());
        }
        self.next_1d_general()
    }

    /// Moves past the value [`Self::next_1d`] would give without computing
    /// it, for a caller that would not read it: the stream is left as
    /// `next_1d` leaves it.
    #[inline]
    pub fn skip_1d(&mut self) {
        // Sobol's values are a pure function of the dimension, so moving
        // past one is counting it (as next_1d_general does).
        if let SamplerKind::Independent | SamplerKind::Sobol = self.sampler.kind {
            self.dim += 1;
        } else {
            self.next_1d_general();
        }
    }

    /// [`Self::skip_1d`] for [`Self::next_2d`].
    #[inline]
    pub fn skip_2d(&mut self) {
        match self.sampler.kind {
            // `independent_2d`: one hash, one dimension.
            SamplerKind::Independent => self.dim += 1,
            // `next_2d_general`'s pair of one set, without its values.
            SamplerKind::Sobol => self.dim = Self::sobol_pair(self.dim) + 2,
            _ => {
                self.next_2d_general();
            }
        }
    }

    /// [`Self::next_1d`] for every sampler.
    #[inline(never)]
    fn next_1d_general(&mut self) -> f32 {
        let h = self.next_hash();
        match self.sampler.kind {
            SamplerKind::Independent => to_unit_f32(h),
            SamplerKind::Stratified => {
                let n = self.sampler.spp;
                let perm_seed = (mix64(self.pixel_key ^ self.dim as u64) >> 32) as u32;
                let stratum = permute(self.index % n, n, perm_seed);
                ((stratum as f32 + to_unit_f32(h)) / n as f32).min(ONE_MINUS_EPS)
            }
            SamplerKind::Multijitter { jitter } => {
                let (i, seed) = self.index_and_seed();
                let j = if jitter { to_unit_f32(h) } else { 0.5 };
                sequences::multijitter_1d(i, self.sampler.spp, seed, j)
            }
            SamplerKind::Orthogonal { jitter } => {
                let j = if jitter { to_unit_f32(h) } else { 0.5 };
                self.orthogonal(j)
            }
            SamplerKind::LowDiscrepancy => {
                let (i, seed) = self.index_and_seed();
                let scramble = (self.sequence_key(0x48bc48eb) >> 32) as u32;
                sequences::radical_inverse_2(permute(i, self.sampler.spp, seed), scramble)
            }
            SamplerKind::Sobol => {
                let d = self.dim - 1;
                self.sobol_set(d / 4)[(d % 4) as usize]
            }
        }
    }

    /// The first dimension of the Sobol' pair a 2D draw at `dim` takes: the
    /// next even one, so the pair is (0, 1) or (2, 3) of one set.
    #[inline]
    fn sobol_pair(dim: u32) -> u32 {
        (dim + 1) & !1
    }

    /// The four values of a dimension set (see [`SamplerKind::Sobol`]).
    #[inline]
    fn sobol_set(&mut self, set: u32) -> [f32; 4] {
        if self.sobol_set != set {
            let (i, seed) = self.sobol_index_and_seed(set);
            self.sobol = sequences::sobol_4d_first_set(i, seed);
            self.sobol_set = set;
        }
        self.sobol
    }

    /// The index within a block of 2^16 samples (the most `sobol_burley`
    /// stratifies) and a seed unique to (seed, pixel, block, dimension set).
    #[inline]
    fn sobol_index_and_seed(&self, set: u32) -> (u32, u32) {
        let block = (self.index >> 16) as u64;
        let h = mix64(self.pixel_key ^ mix64((block << 32) | set as u64));
        (self.index & 0xffff, (h >> 32) as u32)
    }

    /// The sample index within its pass and a permutation seed unique to
    /// (seed, pixel, pass, dimension).
    #[inline]
    fn index_and_seed(&self) -> (u32, u32) {
        let n = self.sampler.spp;
        let (pass, i) = (self.index / n, self.index % n);
        let h = mix64(self.pixel_key ^ mix64(((pass as u64) << 32) | self.dim as u64));
        (i, (h >> 32) as u32)
    }

    /// A per-(pixel, pass) key, identical across dimensions.
    #[inline]
    fn sequence_key(&self, salt: u64) -> u64 {
        let pass = (self.index / self.sampler.spp) as u64;
        mix64(self.pixel_key ^ mix64((pass << 32) | salt))
    }

    /// One coordinate of the orthogonal array, for the dimension just counted.
    #[inline]
    fn orthogonal(&self, jitter: f32) -> f32 {
        let r = self.sampler.res.0;
        // Bose's array has r + 1 orthogonal columns; past them (Mitsuba
        // repeats columns there) a fresh, independently permuted array starts.
        // Blocks have even size so that next_2d's pairs stay in one block.
        let block = (r + 1) & !1;
        let j = self.dim - 1;
        let (b, col) = (j / block.max(1), j % block.max(1));
        let pass = (self.index / self.sampler.spp) as u64;
        let key = mix64(self.pixel_key ^ mix64((pass << 32) | (b as u64) << 1 | 1));
        sequences::bose(self.index % self.sampler.spp, col, r, key, jitter)
    }

    /// The next point in [0, 1)², stratified jointly where the kind allows
    /// (orthogonal takes two dimensions; Sobol' starts on an even one).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if let SamplerKind::Independent = self.sampler.kind {
            return self.independent_2d();
        }
        self.next_2d_general()
    }

    /// The independent sampler's next 2D value: two 24-bit floats from one
    /// 64-bit hash.
    #[inline(always)]
    fn independent_2d(&mut self) -> Vec2 {
        let h = self.next_hash();
        Vec2::new(to_unit_f32(h), to_unit_f32(h << 24))
    }

    /// [`Self::next_2d`] for every sampler.
    #[inline(never)]
    fn next_2d_general(&mut self) -> Vec2 {
        match self.sampler.kind {
            SamplerKind::Independent => self.independent_2d(),
            SamplerKind::Stratified => {
                let h = self.next_hash();
                let res = (self.sampler.spp as f32).sqrt() as u32;
                let n = res * res;
                if n <= 1 || self.index >= n {
                    return Vec2::new(to_unit_f32(h), to_unit_f32(h << 24));
                }
                let perm_seed = (mix64(self.pixel_key ^ self.dim as u64) >> 32) as u32;
                let s = permute(self.index, n, perm_seed);
                let (sx, sy) = (s % res, s / res);
                Vec2::new(
                    ((sx as f32 + to_unit_f32(h)) / res as f32).min(ONE_MINUS_EPS),
                    ((sy as f32 + to_unit_f32(h << 24)) / res as f32).min(ONE_MINUS_EPS),
                )
            }
            SamplerKind::Multijitter { jitter } => {
                let h = self.next_hash();
                let (i, seed) = self.index_and_seed();
                let j = if jitter { Vec2::new(to_unit_f32(h), to_unit_f32(h << 24)) } else { Vec2::splat(0.5) };
                sequences::multijitter_2d(i, self.sampler.res, seed, j)
            }
            SamplerKind::Orthogonal { .. } => Vec2::new(self.next_1d(), self.next_1d()),
            SamplerKind::Sobol => {
                // Start on an even dimension, so the pair is (0, 1) or (2, 3)
                // of one set: Sobol's first two dimensions form a (0, 2)-net.
                let d = Self::sobol_pair(self.dim);
                self.dim = d + 2;
                let v = self.sobol_set(d / 4);
                let c = (d % 4) as usize;
                Vec2::new(v[c], v[c + 1])
            }
            SamplerKind::LowDiscrepancy => {
                self.dim += 1;
                let (i, seed) = self.index_and_seed();
                let k = self.sequence_key(0x98bc51ab);
                let i = permute(i, self.sampler.spp, seed);
                Vec2::new(sequences::radical_inverse_2(i, k as u32), sequences::sobol_2(i, (k >> 32) as u32))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_coordinates() {
        let s = Sampler::new(SamplerKind::Independent, 7, 16);
        let a: Vec<f32> = {
            let mut st = s.stream((3, 4), 5);
            (0..10).map(|_| st.next_1d()).collect()
        };
        let b: Vec<f32> = {
            let mut st = s.stream((3, 4), 5);
            (0..10).map(|_| st.next_1d()).collect()
        };
        assert_eq!(a, b);
        let c = s.stream((4, 3), 5).next_1d();
        assert_ne!(a[0], c);
    }

    /// Owen-scrambled Sobol' keeps the net properties: the first 16 samples
    /// of every 2D pair fill each elementary interval of area 1/16 once
    /// (a (0, 4, 2)-net), and every 1D projection has one sample per 1/16.
    #[test]
    fn sobol_pairs_are_0_2_nets_and_1d_projections_stratify() {
        let s = Sampler::new(SamplerKind::Sobol, 3, 16);
        for pixel in [(0, 0), (5, 9)] {
            // Draw pattern: 1D, 2D (skips to dimension 2), 2D, 1D, 2D (skips to 8).
            let draws: Vec<(f32, Vec2, Vec2, f32, Vec2)> = (0..16)
                .map(|i| {
                    let mut st = s.stream(pixel, i);
                    (st.next_1d(), st.next_2d(), st.next_2d(), st.next_1d(), st.next_2d())
                })
                .collect();
            for pair in 0..3 {
                let pts: Vec<Vec2> = draws.iter().map(|d| [d.1, d.2, d.4][pair]).collect();
                for log_x in 0..=4 {
                    let (nx, ny) = (1usize << log_x, 1usize << (4 - log_x));
                    let mut seen = vec![false; 16];
                    for p in &pts {
                        let cell = (p.x * nx as f32) as usize + nx * (p.y * ny as f32) as usize;
                        assert!(!seen[cell], "pixel {pixel:?} pair {pair}: {nx}x{ny} cell {cell} twice");
                        seen[cell] = true;
                    }
                }
            }
            for dim in [0usize, 1] {
                let mut seen = vec![false; 16];
                for d in &draws {
                    let k = ([d.0, d.3][dim] * 16.0) as usize;
                    assert!(!seen[k], "1D draw {dim}: stratum {k} twice");
                    seen[k] = true;
                }
            }
        }
        // Past 2^16 samples a new, independently scrambled block starts.
        let a = s.stream((1, 1), 3).next_2d();
        let b = s.stream((1, 1), 3 + (1 << 16)).next_2d();
        assert!(a != b && b.x < 1.0 && b.y < 1.0);
    }

    #[test]
    fn stratified_1d_puts_one_sample_in_each_stratum() {
        let n = 16;
        let s = Sampler::new(SamplerKind::Stratified, 1, n);
        for dim in 0..4 {
            let mut hit = vec![false; n as usize];
            for i in 0..n {
                let mut st = s.stream((9, 2), i);
                let u = (0..=dim).map(|_| st.next_1d()).last().unwrap();
                let k = (u * n as f32) as usize;
                assert!(!hit[k], "dimension {dim}: stratum {k} twice");
                hit[k] = true;
            }
        }
    }

    #[test]
    fn stratified_2d_covers_the_grid() {
        let s = Sampler::new(SamplerKind::Stratified, 3, 16);
        let mut hit = [false; 16];
        for i in 0..16 {
            let u = s.stream((0, 0), i).next_2d();
            let k = (u.y * 4.0) as usize * 4 + (u.x * 4.0) as usize;
            assert!(!hit[k]);
            hit[k] = true;
        }
    }

    /// Skipping a number leaves the stream where drawing it does, for every
    /// kind and every mix of 1D and 2D draws: the numbers after a skip are
    /// bitwise those after the draw.
    #[test]
    fn skips_leave_the_stream_where_draws_do() {
        let kinds =
            [SamplerKind::Independent, SamplerKind::Stratified, SamplerKind::Sobol].into_iter().chain(NEW_KINDS);
        for kind in kinds {
            let s = Sampler::new(kind, 11, 16);
            for (pixel, i) in [((0, 0), 0), ((5, 9), 3), ((2, 7), 15), ((1, 1), 21)] {
                // Draw pattern by bit: 1 a 2D number, 0 a 1D one; each
                // position is skipped in turn.
                for pattern in [0b0000_0000u32, 0b0110_1101, 0b1111_1111, 0b1001_0010] {
                    let draw = |st: &mut SampleStream, k: u32, skip: bool| -> Vec<f32> {
                        match (pattern >> k & 1 == 1, skip) {
                            (true, false) => st.next_2d().to_array().to_vec(),
                            (false, false) => vec![st.next_1d()],
                            (true, true) => {
                                st.skip_2d();
                                vec![]
                            }
                            (false, true) => {
                                st.skip_1d();
                                vec![]
                            }
                        }
                    };
                    let mut full = s.stream(pixel, i);
                    let all: Vec<Vec<f32>> = (0..8).map(|k| draw(&mut full, k, false)).collect();
                    for skipped in 0..8 {
                        let mut st = s.stream(pixel, i);
                        for k in 0..8 {
                            let v = draw(&mut st, k, k == skipped);
                            if k != skipped {
                                let same = v.iter().zip(&all[k as usize]).all(|(a, b)| a.to_bits() == b.to_bits());
                                assert!(same, "{kind:?} pattern {pattern:b}: draw {k} after skipping {skipped}");
                            }
                        }
                        assert_eq!(st.dim(), full.dim(), "{kind:?}");
                    }
                }
            }
        }
    }

    const NEW_KINDS: [SamplerKind; 5] = [
        SamplerKind::Multijitter { jitter: true },
        SamplerKind::Multijitter { jitter: false },
        SamplerKind::Orthogonal { jitter: true },
        SamplerKind::Orthogonal { jitter: false },
        SamplerKind::LowDiscrepancy,
    ];

    #[test]
    fn sample_counts_round_as_mitsuba() {
        // mi.load_dict({'type': t, 'sample_count': n}).sample_count() in Mitsuba 3.9.1
        let mj = SamplerKind::Multijitter { jitter: true };
        let or = SamplerKind::Orthogonal { jitter: true };
        let ld = SamplerKind::LowDiscrepancy;
        for (k, n, expect) in [
            (mj, 16, 16),
            (mj, 10, 12),
            (mj, 7, 8),
            (mj, 1, 1),
            (or, 16, 25),
            (or, 25, 25),
            (or, 1, 4),
            (or, 50, 121),
            (ld, 16, 16),
            (ld, 1, 4),
            (ld, 17, 64),
            (ld, 100, 256),
        ] {
            assert_eq!(k.round_sample_count(n), expect, "{k:?} {n}");
            assert_eq!(Sampler::new(k, 0, n).spp, expect);
        }
    }

    /// Every dimension of the first `spp` samples (and of the next pass) puts
    /// one sample in each of `spp` 1D strata; 2D draws cover their grids.
    #[test]
    fn new_samplers_are_stratified_in_every_dimension() {
        for kind in NEW_KINDS {
            for spp in [16u32, 25, 12] {
                let s = Sampler::new(kind, 5, spp);
                let n = s.spp;
                // Grid the 2D points must fill (one point per cell).
                let (gx, gy) = match kind {
                    SamplerKind::Multijitter { .. } => s.res,
                    SamplerKind::Orthogonal { .. } => s.res,
                    _ => {
                        let r = (n as f32).sqrt() as u32;
                        (r, r)
                    }
                };
                for pass in 0..2 {
                    // Draw order: 2D, 1D, 2D, 1D, 1D, 2D, ... (12 dimensions).
                    let pattern = [2, 1, 2, 1, 1, 2, 2, 1];
                    let draws: Vec<Vec<Vec2>> = (0..n)
                        .map(|i| {
                            let mut st = s.stream((3, 7), pass * n + i);
                            pattern
                                .iter()
                                .map(|&d| if d == 2 { st.next_2d() } else { Vec2::new(st.next_1d(), 0.5) })
                                .collect()
                        })
                        .collect();
                    for (k, &d) in pattern.iter().enumerate() {
                        let mut strata = vec![0; n as usize];
                        let mut cells = vec![0; (gx * gy) as usize];
                        for p in draws.iter().map(|v| v[k]) {
                            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                            strata[(p.x * n as f32) as usize] += 1;
                            if d == 2 {
                                cells[((p.y * gy as f32) as u32 * gx + (p.x * gx as f32) as u32) as usize] += 1;
                            }
                        }
                        // ldsampler's 1D points share one scramble: one per stratum too.
                        assert!(strata.iter().all(|&c| c == 1), "{kind:?} spp {n} pass {pass} draw {k}: {strata:?}");
                        if d == 2 {
                            assert!(cells.iter().all(|&c| c == 1), "{kind:?} spp {n} pass {pass} draw {k}: {cells:?}");
                        }
                    }
                }
            }
        }
    }

    /// RMSE of the per-pixel estimate of ∫ f over many pixels (independent
    /// scrambles), drawing `dims2` 2D points per sample.
    fn rmse(kind: SamplerKind, spp: u32, dims2: usize, f: &dyn Fn(&[Vec2]) -> f64, exact: f64) -> f64 {
        let s = Sampler::new(kind, 11, spp);
        let pixels = 2000u32;
        let mut se = 0.0;
        let mut u = vec![Vec2::ZERO; dims2];
        for p in 0..pixels {
            let mut sum = 0.0;
            for i in 0..s.spp {
                let mut st = s.stream((p % 64, p / 64), i);
                for x in u.iter_mut() {
                    *x = st.next_2d();
                }
                sum += f(&u);
            }
            se += (sum / s.spp as f64 - exact).powi(2);
        }
        (se / pixels as f64).sqrt()
    }

    /// At equal sample counts, no sampler has a higher error than
    /// `independent` on smooth integrands, in 2 and in 8 dimensions.
    #[test]
    fn new_samplers_beat_independent_on_smooth_integrals() {
        // ∫∫ exp(x) sin(πy)... = (e − 1) · 2/π over [0,1]².
        let f2 = |u: &[Vec2]| (u[0].x as f64).exp() * (std::f64::consts::PI * u[0].y as f64).sin();
        let exact2 = (std::f64::consts::E - 1.0) * 2.0 / std::f64::consts::PI;
        // A product over 8 dimensions (4 2D draws) with mean 1.
        let f8 = |u: &[Vec2]| {
            u.iter().map(|p| (0.5 + p.x as f64) * (1.0 + 0.5 * (std::f64::consts::TAU * p.y as f64).cos())).product()
        };
        for kind in NEW_KINDS.into_iter().chain([SamplerKind::Sobol]) {
            let spp = kind.round_sample_count(16);
            let i2 = rmse(SamplerKind::Independent, spp, 1, &f2, exact2);
            let s2 = rmse(kind, spp, 1, &f2, exact2);
            let i8 = rmse(SamplerKind::Independent, spp, 4, &f8, 1.0);
            let s8 = rmse(kind, spp, 4, &f8, 1.0);
            eprintln!("{kind:?} spp {spp}: 2D rmse {s2:.2e} vs independent {i2:.2e}; 8D {s8:.2e} vs {i8:.2e}");
            // 2000 pixels: an RMSE estimate's relative spread is about 2 %.
            assert!(s2 < 0.5 * i2, "{kind:?} 2D: {s2} vs {i2}");
            assert!(s8 < i8, "{kind:?} 8D: {s8} vs {i8}");
        }
    }
}
