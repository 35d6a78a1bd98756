#!/usr/bin/env bash
# Instructions per sample of `penumbra render`, counted by callgrind: a
# number that, unlike wall time, does not move with the machine's load.
#
# Builds an AVX2 (x86-64-v3) release binary into target/callgrind (valgrind
# 3.19 cannot run AVX-512 code, so the stream integrator runs packets of 8
# there), renders each scene twice with one thread, at SPP_LO and SPP_HI
# samples per pixel, and prints (Ir(SPP_HI) - Ir(SPP_LO)) / (pixels x
# (SPP_HI - SPP_LO)): the marginal cost of a sample, start-up and image
# writing excluded. Both the stream integrator and --no-stream are counted.
#
# Usage: tools/instructions-per-sample.sh [SCENE.xml ...]
#        (default: the bench scenes; SPP_LO=1 SPP_HI=3 to change the counts)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "valgrind not found: apt-get install valgrind" >&2; exit 1; }
lo=${SPP_LO:-1}
hi=${SPP_HI:-3}
export CARGO_TARGET_DIR="$PWD/target/callgrind"
RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin penumbra
bin="$CARGO_TARGET_DIR/release/penumbra"
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/cornell-box.xml tests/scenes/envmap_sun.xml tests/scenes/rough_spheres.xml
    tests/scenes/many_lights.xml scenes/material-showcase.xml)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Total instructions of one run.
count() {
    valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$bin" render "$@" -o "$tmp/img.exr" \
        --threads 1 --quiet >"$tmp/log" 2>&1 || { cat "$tmp/log" >&2; exit 1; }
    awk '/^summary:/ {print $2}' "$tmp/cg.out"
}
printf '%-34s %12s %12s %8s\n' scene stream one-path ratio
for s in "${scenes[@]}"; do
    pixels=$("$bin" info "$s" 2>/dev/null | awk '/^image:/ {split($2, a, "x"); print a[1] * a[2]; exit}')
    [ -n "$pixels" ] || { echo "$s: no film size in 'penumbra info'" >&2; exit 1; }
    row=()
    for mode in "" "--no-stream"; do
        a=$(count "$s" --spp "$lo" $mode)
        b=$(count "$s" --spp "$hi" $mode)
        row+=("$(( (b - a) / (pixels * (hi - lo)) ))")
    done
    printf '%-34s %12s %12s %8s\n' "$(basename "$s")" "${row[0]}" "${row[1]}" \
        "$(awk -v a="${row[0]}" -v b="${row[1]}" 'BEGIN {printf "%.3f", a / b}')"
done
