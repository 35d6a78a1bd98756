//! The render crate's integration tests, one test binary (each file a module):
//! every test binary costs its own link of the release profile (fat LTO).

mod furnace;
mod media;
mod ray_log;
