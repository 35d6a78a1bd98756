#!/usr/bin/env bash
# Coverage-guided fuzzing of the readers with libFuzzer on the stable
# toolchain (rustc's sanitizer-coverage passes; no nightly, no cargo-fuzz).
#
#   tools/fuzz.sh build                 build every target (fuzz/)
#   tools/fuzz.sh run TARGET [SECONDS]  fuzz TARGET on one core (default 60 s),
#                                       seeded with fuzz/corpus/TARGET
#   tools/fuzz.sh merge TARGET          minimise the corpus and what the runs
#                                       found into fuzz/corpus/TARGET
#
# Targets: xml xml_include obj ply serialized vol spd pfm image pbrt tensor gltf
# (crates/scene/src/fuzzing.rs), checkpoint part (crates/cli/src/fuzzing.rs). A crash is written to
# $CARGO_TARGET_DIR/fuzz-artifacts/TARGET/; fix it, and add the input to the
# corpus as regression-NAME (merge keeps those, and the seed-* files) so that the replay test
# (crates/scene/tests/fuzz_corpus.rs) keeps checking it.
# Needs a C++ compiler (libFuzzer is built from source by libfuzzer-sys).
set -euo pipefail
cd "$(dirname "$0")/.."
target_dir=${CARGO_TARGET_DIR:-$PWD/target}/fuzz
triple=$(rustc -vV | sed -n 's/^host: //p')
bin() { echo "$target_dir/$triple/release/$1"; }
build() {
    # --target keeps the instrumentation off build scripts and proc macros.
    RUSTFLAGS="--cfg fuzzing -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares -Cdebug-assertions -Coverflow-checks" \
        cargo build --release --manifest-path fuzz/Cargo.toml --target "$triple" --target-dir "$target_dir" "$@"
}
case "${1:-}" in
build)
    build
    ;;
run)
    t=${2:?target}
    secs=${3:-60}
    build --bin "$t"
    work="$target_dir/work/$t"
    art="$target_dir/../fuzz-artifacts/$t"
    mkdir -p "$work" "$art" "fuzz/corpus/$t"
    # New inputs go to $work; the committed corpus seeds the run.
    "$(bin "$t")" -max_total_time="$secs" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
        -max_len=65536 -print_final_stats=1 -artifact_prefix="$art/" "$work" "fuzz/corpus/$t"
    ;;
merge)
    t=${2:?target}
    build --bin "$t"
    work="$target_dir/work/$t"
    mkdir -p "$work"
    new=$(mktemp -d)
    "$(bin "$t")" -set_cover_merge=1 -rss_limit_mb=2048 -timeout=10 "$new" "fuzz/corpus/$t" "$work"
    # Inputs that once crashed stay, whatever coverage they add, and so do
    # the hand-made seeds (tests read some of them by name).
    find "fuzz/corpus/$t" \( -name 'regression-*' -o -name 'seed-*' \) -exec cp {} "$new/" \;
    rm -rf "fuzz/corpus/$t"
    mv "$new" "fuzz/corpus/$t"
    chmod 755 "fuzz/corpus/$t"
    echo "fuzz/corpus/$t: $(ls "fuzz/corpus/$t" | wc -l) files, $(du -sh "fuzz/corpus/$t" | cut -f1)"
    ;;
*)
    sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
