//! Penumbra's rendering core. No file formats live here: the `penumbra-scene`
//! crate builds a [`scene::Scene`] and this crate renders it.
//!
//! Layers, bottom up: `math` → `sampling` → `geometry` → `accel` →
//! `bsdf` / `light` / `camera` / `film` → `scene` → `integrator` → `render`.

pub mod geometry;
