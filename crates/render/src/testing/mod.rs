//! Statistical test harnesses shared by the unit tests.

pub mod chi2;

/// A small deterministic random stream for tests (counter hashing).
pub struct TestRng {
    seed: u64,
    i: u64,
}

impl TestRng {
    /// The stream of `seed`, from its start.
    pub fn new(seed: u64) -> TestRng {
        TestRng { seed, i: 0 }
    }
    /// The next uniform number in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.i += 1;
        crate::sampling::rng::to_unit_f32(crate::sampling::rng::hash_words(&[self.seed, self.i]))
    }
    /// The next two uniform numbers in [0, 1)².
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }
}
