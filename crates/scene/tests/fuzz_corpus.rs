//! Replays the committed fuzzing corpus (`fuzz/corpus/<target>/`: the
//! minimised inputs that `tools/fuzz.sh` found, every crash found among
//! them) through the readers' fuzz entry points, so that every test run
//! checks them without the fuzzer: no input may panic or take long.

use penumbra_scene::fuzzing::TARGETS;
use std::path::Path;
use std::time::{Duration, Instant};

/// Far above any input's time in a debug build, far below a hang.
const LIMIT: Duration = Duration::from_secs(20);

#[test]
fn the_fuzzing_corpus_replays_without_a_panic_or_a_hang() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    // Every target has its corpus (crates/cli/tests/fuzz_corpus.rs checks
    // that every directory belongs to a target of this crate or of the CLI's).
    for (name, _) in TARGETS {
        assert!(corpus.join(name).is_dir(), "fuzz/corpus/{name} is missing");
    }
    let mut failures = Vec::new();
    let mut count = 0;
    for (name, run) in TARGETS {
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
