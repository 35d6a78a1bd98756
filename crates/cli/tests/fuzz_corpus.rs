//! Replays the committed fuzzing corpus of the command line's readers
//! (`fuzz/corpus/checkpoint`, `fuzz/corpus/part`; see `penumbra::fuzzing`)
//! without the fuzzer: no input may panic or take long. The scene readers'
//! corpus is replayed by crates/scene/tests/fuzz_corpus.rs.

use std::path::Path;
use std::time::{Duration, Instant};

/// Far above any input's time in a debug build, far below a hang.
const LIMIT: Duration = Duration::from_secs(20);

#[test]
fn every_corpus_directory_belongs_to_a_target() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let mut dirs: Vec<String> = std::fs::read_dir(&corpus)
        .unwrap_or_else(|e| panic!("{}: {e}", corpus.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    dirs.sort();
    let mut names: Vec<&str> =
        penumbra::fuzzing::TARGETS.iter().chain(penumbra_scene::fuzzing::TARGETS).map(|t| t.0).collect();
    names.sort();
    assert_eq!(dirs, names, "fuzz/corpus/ must hold one directory per target");
}

/// fuzz/Cargo.toml (a manifest outside the workspace, so no workspace
/// build reads it) declares each target once, as one `[[bin]]` table with
/// its name, its `fuzz_targets/NAME.rs` and no second key of either.
#[test]
fn the_fuzz_manifest_declares_every_target_once() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut declared: Vec<String> = Vec::new();
    for (i, table) in text.split("[[bin]]").enumerate().skip(1) {
        let values = |key: &str| -> Vec<String> {
            table
                .lines()
                .take_while(|l| !l.trim_start().starts_with('['))
                .filter_map(|l| l.split_once('=').filter(|(k, _)| k.trim() == key))
                .map(|(_, v)| v.trim().trim_matches('"').to_string())
                .collect()
        };
        let (names, paths) = (values("name"), values("path"));
        assert!(names.len() == 1 && paths.len() == 1, "[[bin]] table {i}: names {names:?}, paths {paths:?}");
        assert_eq!(paths[0], format!("fuzz_targets/{}.rs", names[0]), "[[bin]] table {i}");
        declared.push(names[0].clone());
    }
    declared.sort();
    let mut names: Vec<&str> =
        penumbra::fuzzing::TARGETS.iter().chain(penumbra_scene::fuzzing::TARGETS).map(|t| t.0).collect();
    names.sort();
    assert_eq!(declared, names, "fuzz/Cargo.toml must declare one [[bin]] per target");
}

#[test]
fn the_cli_fuzzing_corpus_replays_without_a_panic_or_a_hang() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let mut failures = Vec::new();
    let mut count = 0;
    for (name, run) in penumbra::fuzzing::TARGETS {
        let mut files: Vec<_> = std::fs::read_dir(corpus.join(name)).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        assert!(!files.is_empty(), "fuzz/corpus/{name} is empty");
        for file in files {
            let data = std::fs::read(&file).unwrap();
            let t0 = Instant::now();
            if std::panic::catch_unwind(|| run(&data)).is_err() {
                failures.push(format!("{name}: {} panicked", file.display()));
            }
            if t0.elapsed() > LIMIT {
                failures.push(format!("{name}: {} took {:.1} s", file.display(), t0.elapsed().as_secs_f64()));
            }
            count += 1;
        }
    }
    assert!(failures.is_empty(), "{} of {count} inputs failed:\n{}", failures.len(), failures.join("\n"));
    eprintln!("{count} corpus inputs replayed");
}

/// The seeds reach the readers' success paths: a checkpoint seed decodes,
/// and a part seed merges (so the corpus does not only test rejections).
#[test]
fn the_seeds_are_valid_inputs() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let ck = std::fs::read(corpus.join("checkpoint/seed-aov")).unwrap();
    penumbra::checkpoint::Checkpoint::decode(&ck, "seed-aov").unwrap();
    let ck = std::fs::read(corpus.join("checkpoint/seed-guided")).unwrap();
    let guided = penumbra::checkpoint::Checkpoint::decode(&ck, "seed-guided").unwrap();
    assert!(guided.guide.is_some_and(|g| g.trained()), "seed-guided holds no trained guide");
    // A ZIP-compressed part (as penumbra writes them) and an RLE one (the exr
    // crate's default, as other tools may write them).
    for seed in ["seed-part", "seed-part-rle"] {
        let part = std::fs::read(corpus.join("part").join(seed)).unwrap();
        let dir = tempfile_dir();
        std::fs::write(dir.join("p.exr"), &part[1..]).unwrap();
        let args = penumbra::args::MergeArgs {
            inputs: vec![dir.join("p.exr")],
            output: dir.join("m.exr"),
            allow_missing: true,
        };
        penumbra::merge::run(&args).unwrap_or_else(|e| panic!("{seed}: {e:#}"));
        assert!(dir.join("m.exr").exists(), "{seed}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-fuzz-seeds-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
