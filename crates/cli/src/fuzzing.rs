//! The command line's readers as fuzz targets see them (the scene readers'
//! are `penumbra_scene::fuzzing`): each takes arbitrary bytes and must
//! return, never panic, hang or allocate what the data does not back.
//! `fuzz/` drives them with libFuzzer; `tests/fuzz_corpus.rs` replays the
//! committed corpus through them in every test run.

use crate::args::MergeArgs;
use crate::checkpoint::Checkpoint;
use std::path::{Path, PathBuf};

/// A target's entry point.
pub type Target = fn(&[u8]);

/// The targets by name (directories of `fuzz/corpus/`), with their entry points.
pub const TARGETS: &[(&str, Target)] = &[("checkpoint", checkpoint), ("part", part)];

/// A checkpoint file (`--checkpoint`), decoded as a resumed render reads it:
/// as given, and with a correct CRC-32 appended: a
/// mutation almost never keeps the checksum right, so without the second
/// the parser behind it (film, layers, the path guide) would go unexplored.
pub fn checkpoint(data: &[u8]) {
    let _ = Checkpoint::decode(data, "fuzz.ckpt");
    let mut fixed = data.to_vec();
    fixed.extend_from_slice(&crc32fast::hash(data).to_le_bytes());
    let _ = Checkpoint::decode(&fixed, "fuzz.ckpt");
}

/// A part EXR given to `penumbra merge`: the first byte chooses whether it
/// is merged alone or twice over (a duplicate part), the rest is the file.
pub fn part(data: &[u8]) {
    let Some((&which, rest)) = data.split_first() else { return };
    let dir = scratch_dir();
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let input = dir.join("part.exr");
    if std::fs::write(&input, rest).is_ok() {
        let inputs = if which % 2 == 0 { vec![input.clone()] } else { vec![input.clone(), input.clone()] };
        let args = MergeArgs { inputs, output: dir.join("merged.exr"), allow_missing: which & 2 != 0 };
        let _ = crate::merge::run(&args);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A directory of this process and thread, for targets that read files.
fn scratch_dir() -> PathBuf {
    Path::new(&std::env::temp_dir())
        .join(format!("penumbra-fuzz-{}-{:?}", std::process::id(), std::thread::current().id()).replace(['(', ')'], ""))
}
