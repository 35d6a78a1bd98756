//! Samplers (Mitsuba `independent` and `stratified`). A sampler hands out a
//! [`SampleStream`] per (pixel, sample index); the stream's values depend
//! only on (seed, pixel, sample index, dimension).

use super::rng::{hash_words, mix64, permute, to_unit_f32};
use glam::Vec2;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent uniform random numbers.
    Independent,
    /// Jittered strata per dimension, sample indices shuffled per dimension
    /// (as Mitsuba's `stratified` with `jitter` = true).
    Stratified,
}

#[derive(Debug, Clone, Copy)]
pub struct Sampler {
    pub kind: SamplerKind,
    pub seed: u64,
    /// Samples per pixel of the whole render (stratification needs it).
    pub spp: u32,
}

impl Sampler {
    pub fn new(kind: SamplerKind, seed: u64, spp: u32) -> Sampler {
        Sampler { kind, seed, spp: spp.max(1) }
    }

    /// The random stream of one pixel sample.
    #[inline]
    pub fn stream(&self, pixel: (u32, u32), sample_index: u32) -> SampleStream {
        let pixel_key = hash_words(&[self.seed, ((pixel.1 as u64) << 32) | pixel.0 as u64]);
        SampleStream {
            pixel_key,
            key: mix64(pixel_key ^ (sample_index as u64).wrapping_mul(0xd1b54a32d192ed03)),
            dim: 0,
            index: sample_index,
            sampler: *self,
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
}

impl SampleStream {
    #[inline]
    fn next_hash(&mut self) -> u64 {
        self.dim += 1;
        mix64(self.key ^ (self.dim as u64).wrapping_mul(0x9e3779b97f4a7c15))
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let h = self.next_hash();
        match self.sampler.kind {
            SamplerKind::Independent => to_unit_f32(h),
            SamplerKind::Stratified => {
                let n = self.sampler.spp;
                let perm_seed = (mix64(self.pixel_key ^ self.dim as u64) >> 32) as u32;
                let stratum = permute(self.index % n, n, perm_seed);
                ((stratum as f32 + to_unit_f32(h)) / n as f32).min(ONE_MINUS_EPS)
            }
        }
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match self.sampler.kind {
            SamplerKind::Independent => {
                let h = self.next_hash();
                // Two 24-bit floats from one 64-bit hash.
                Vec2::new(to_unit_f32(h), to_unit_f32(h << 24))
            }
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
        }
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

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
}
