//! Sampling: counter-based random numbers, samplers, warps from the unit
//! square to other domains, discrete distributions and MIS heuristics.
//!
//! Naming rule: `sample_x(u) -> point` and `x_pdf(point) -> density`, with
//! the density's measure stated in the doc comment.

pub mod continuous1d;
pub mod distrib1d;
pub mod distrib2d;
pub mod marginal2d;
pub mod mis;
pub mod reservoir;
pub mod rng;
pub mod sampler;
pub mod sequences;
pub mod warp;

pub use continuous1d::ContinuousDistribution;
pub use distrib1d::Distribution1D;
pub use distrib2d::Distribution2D;
pub use sampler::{SampleStream, Sampler, SamplerKind};
