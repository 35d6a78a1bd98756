//! The scene crate's tests, one test binary (each file a module): every test
//! binary costs its own link of the release profile (fat LTO). `sunsky.rs` is
//! its own binary: it points `PENUMBRA_SUNSKY_DATA` elsewhere for a while, which
//! would race with the tests here that read the tables.

mod common;

mod builder;
mod caustics;
mod channels;
mod estimators;
mod format;
mod fuzz_corpus;
mod gltf;
mod hostile;
mod materials;
mod measured;
mod media;
mod mitsuba_xml;
mod pbrt_scenes;
mod plugins;
mod ptracer;
mod references;
mod scene_builder;
mod sensors;
mod shapes;
mod spectra;
mod stream;
mod stress;
mod tensor;
mod textures;
