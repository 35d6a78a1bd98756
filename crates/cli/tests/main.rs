//! The end-to-end tests of the `penumbra` binary, one test binary (each file a
//! module): every test binary costs its own link of the release profile (fat
//! LTO), which made most of CI's compile time.

mod common;

mod aov;
mod cli;
mod diff;
mod display_server;
mod examples;
mod full_disk;
mod fuzz_corpus;
mod hostile_inputs;
mod info;
mod integrators;
mod preview;
mod production;
