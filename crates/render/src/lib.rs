//! Penumbra's rendering core. No file formats live here: the `penumbra-scene`
//! crate builds a [`render::RenderJob`] and this crate renders it.
//!
//! Layers, bottom up: `math` / `simd` → `sampling` → `geometry` → `accel` →
//! `texture` → `bsdf` → `material` / `light` / `camera` / `film` / `medium` → `scene` → `guiding` → `integrator` → `render`.

#![warn(missing_docs)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod film;
pub mod geometry;
pub mod guiding;
pub mod integrator;
pub mod light;
pub mod material;
pub mod math;
pub mod medium;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod simd;
#[cfg(test)]
pub mod testing;
pub mod texture;
