#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| penumbra_scene::fuzzing::gltf(data));
