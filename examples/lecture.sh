#!/usr/bin/env bash
# Renders the figures of the path-tracing lecture into docs/lecture/ (PNGs and
# a README.md table: figure | settings | spp | time s | relMSE).
#
#   examples/lecture.sh            # build, render, write docs/lecture/
#   examples/lecture.sh --fresh    # also re-render the cached references
#
# Each figure is rendered twice with the same seed (bitwise identical: once as
# EXR to measure, once as PNG to show) and compared with `penumbra diff`
# against a converged render of its scene: the `path` integrator (MIS) at
# high spp with another seed. References are cached under
# $CARGO_TARGET_DIR/lecture/ (default target/lecture/), keyed by the scene
# file and the render arguments; re-render them with --fresh after changing
# the renderer. Environment: THREADS (default: all cores), REF_SCALE (scales
# every reference's spp, default 1), EQUAL_TIME (seconds per strategy in
# figure f, default 3).
set -euo pipefail

cd "$(dirname "$0")/.."
ROOT=$PWD
FRESH=0
for arg in "$@"; do
    case $arg in
    --fresh) FRESH=1 ;;
    *)
        echo "usage: examples/lecture.sh [--fresh]" >&2
        exit 2
        ;;
    esac
done

TARGET=${CARGO_TARGET_DIR:-target}
case $TARGET in /*) ;; *) TARGET=$ROOT/$TARGET ;; esac
BIN=$TARGET/release/penumbra
CACHE=$TARGET/lecture
OUT=docs/lecture
STAGE=$CACHE/stage
REF_SCALE=${REF_SCALE:-1}
EQUAL_TIME=${EQUAL_TIME:-3}
REF_SEED=1000003
THREAD_ARGS=()
[ -n "${THREADS:-}" ] && THREAD_ARGS=(--threads "$THREADS")

die() {
    echo "error: $*" >&2
    exit 1
}

echo "== building (cargo build --release)"
cargo build --release -p penumbra || die "cargo build failed"
[ -x "$BIN" ] || die "no binary at $BIN"

mkdir -p "$CACHE/ref" "$CACHE/fig"
rm -rf "$STAGE"
mkdir -p "$STAGE"

# render OUT SCENE ARGS...: renders, dies with the log on failure, sets
# RENDER_TIME to the render's own time (seconds, from its summary line).
render() {
    local out=$1 scene=$2
    shift 2
    local log=$CACHE/render.log
    if ! "$BIN" render "$scene" -o "$out" --quiet "${THREAD_ARGS[@]}" "$@" 2>"$log"; then
        echo "error: render failed: penumbra render $scene -o $out $*" >&2
        cat "$log" >&2
        exit 1
    fi
    RENDER_TIME=$(sed -n 's/^rendered .* in \([0-9.]*\) s: .*/\1/p' "$log")
    [ -n "$RENDER_TIME" ] || die "no timing in the output of: penumbra render $scene $*"
    if grep -q '^warning' "$log"; then
        echo "   $(grep '^warning' "$log")"
        WARNINGS+=("$(basename "$out"): $(grep '^warning' "$log")")
    fi
}

# relmse IMAGE REFERENCE: sets RELMSE.
relmse() {
    local out
    out=$("$BIN" diff "$1" "$2") || die "penumbra diff $1 $2 failed"
    RELMSE=$(awk '/^relMSE:/ { print $2 }' <<<"$out")
    [ -n "$RELMSE" ] || die "no relMSE in the output of penumbra diff $1 $2"
}

# reference NAME SCENE SPP INTEGRATOR ARGS...: the converged render of a scene
# (cached), its path in REF_EXR; a PNG of it at a quarter of the spp goes to
# the gallery as NAME-reference.png.
declare -A REF_EXR_OF REF_DESC_OF
reference() {
    local name=$1 scene=$2 spp=$3 integ=$4
    shift 4
    spp=$(awk -v s="$spp" -v k="$REF_SCALE" 'BEGIN { n = int(s * k + 0.5); print (n < 1 ? 1 : n) }')
    local args=(--spp "$spp" --seed "$REF_SEED" --integrator "$integ" "$@")
    local key
    key=$({ cat "$scene"; printf '%s\n' "${args[@]}"; } | sha256sum | cut -c1-16)
    local exr=$CACHE/ref/$name-$key.exr png=$CACHE/ref/$name-$key.png
    # Drop this scene's references for other settings.
    find "$CACHE/ref" -name "$name-*" ! -name "$name-$key.*" -delete
    if [ "$FRESH" = 1 ] || [ ! -f "$exr" ] || [ ! -f "$png" ]; then
        echo "== reference $name: $integ, $spp spp (cached afterwards)"
        render "$exr" "$scene" "${args[@]}"
        echo "   $RENDER_TIME s"
        local spp_png=$(((spp + 3) / 4))
        render "$png" "$scene" --spp "$spp_png" --seed $((REF_SEED + 1)) --integrator "$integ" "$@"
    else
        echo "== reference $name: cached ($exr)"
    fi
    cp "$png" "$STAGE/$name-reference.png"
    REF_EXR_OF[$name]=$exr
    REF_DESC_OF[$name]="\`$integ\` at $spp spp (shown: $(((spp + 3) / 4)) spp)"
}

ROWS=()      # summary table rows
BUDGET=""    # seconds per figure in an equal-time group
WARNINGS=()
declare -A GALLERY_IMG GALLERY_CAP

# figure GROUP ID REF SCENE SPP INTEGRATOR ARGS...: renders one figure.
figure() {
    local group=$1 id=$2 ref=$3 scene=$4 spp=$5 integ=$6
    shift 6
    local args=(--spp "$spp" --integrator "$integ" "$@")
    printf '   %-12s %5s spp  %-44s ' "$id" "$spp" "$integ"
    render "$CACHE/fig/$id.exr" "$scene" "${args[@]}"
    local t=$RENDER_TIME
    if [ -n "$BUDGET" ]; then
        # Equal time: one correction if the render missed the budget by > 15 %.
        local spp2
        spp2=$(awk -v t="$t" -v b="$BUDGET" -v n="$spp" \
            'BEGIN { if (t > 0 && (t > 1.15 * b || t < b / 1.15)) { m = int(n * b / t + 0.5); print (m < 1 ? 1 : m) } }')
        if [ -n "$spp2" ]; then
            printf '%.2f s, again at %s spp ... ' "$t" "$spp2"
            spp=$spp2
            args=(--spp "$spp" --integrator "$integ" "$@")
            render "$CACHE/fig/$id.exr" "$scene" "${args[@]}"
            t=$RENDER_TIME
        fi
    fi
    render "$STAGE/$id.png" "$scene" "${args[@]}"
    relmse "$CACHE/fig/$id.exr" "${REF_EXR_OF[$ref]}"
    local rel
    rel=$(printf '%.3e' "$RELMSE")
    printf '%6.2f s   relMSE %s\n' "$t" "$rel"
    ROWS+=("| [$id]($id.png) | \`$integ\` | $spp | $(printf '%.2f' "$t") | $rel |")
    GALLERY_IMG[$group]+="| ![$id]($id.png) "
    local extra=""
    [ -n "$BUDGET" ] && extra="<br>relMSE × time $(awk -v r="$RELMSE" -v t="$t" 'BEGIN { printf "%.2e", r * t }')"
    GALLERY_CAP[$group]+="| \`$integ\`<br>$spp spp, $(printf '%.2f' "$t") s<br>relMSE $rel$extra "
}

# Closes a group's gallery with its reference image.
gallery_reference() {
    local group=$1 ref=$2
    GALLERY_IMG[$group]+="| ![reference]($ref-reference.png) |"
    GALLERY_CAP[$group]+="| reference:<br>${REF_DESC_OF[$ref]} |"
}

BOX=examples/cornell-diffuse.xml
SOFT=examples/soft-shadows.xml
ENV=examples/envmap.xml
MANY=tests/scenes/many_lights.xml
MANY_ARGS=(-D res=128)

reference box "$BOX" 1024 path
reference soft "$SOFT" 1024 path
reference env "$ENV" 1024 path
reference many "$MANY" 8192 path:light_selection=power "${MANY_ARGS[@]}"

echo "== a. brute force (cosine-weighted hemisphere sampling)"
for n in 1 100 1000; do
    figure a "a-${n}spp" box "$BOX" "$n" bruteforce:sampling=cosine
done
gallery_reference a box

echo "== b. light sampling: N shadow rays, 1 spp"
for n in 1 9 36 100; do
    figure b "b-${n}rays" soft "$SOFT" 1 "direct:emitter_samples=$n,bsdf_samples=0"
done
gallery_reference b soft

echo "== c. direct only, one bounce, five bounces (equal spp)"
for d in 2 3 6; do
    figure c "c-depth$d" box "$BOX" 64 "path:max_depth=$d"
done
gallery_reference c box

echo "== d. uniform vs cosine vs BSDF sampling (equal spp)"
for s in uniform cosine bsdf; do
    figure d "d-$s" box "$BOX" 64 "bruteforce:sampling=$s"
done
gallery_reference d box

echo "== e. environment map lighting (equal spp)"
figure e e-bruteforce env "$ENV" 32 bruteforce:sampling=cosine
figure e e-nomis env "$ENV" 32 path:mis=false
figure e e-mis env "$ENV" 32 path
gallery_reference e env

echo "== f. light selection with 100 lights at equal time (${EQUAL_TIME} s each)"
STRATEGIES=(uniform power)
if "$BIN" render "$MANY" -o "$CACHE/bvh-probe.exr" --quiet --spp 1 -D res=8 \
    --integrator path:light_selection=bvh 2>/dev/null; then
    STRATEGIES+=(bvh)
else
    echo "   (light_selection=bvh is not available: skipped)"
fi
BUDGET=$EQUAL_TIME
for s in "${STRATEGIES[@]}"; do
    # Seconds per spp from a short run, then the spp that fills the budget.
    render "$CACHE/fig/f-probe.exr" "$MANY" --spp 16 --integrator "path:light_selection=$s" "${MANY_ARGS[@]}"
    spp=$(awk -v t="$RENDER_TIME" -v b="$EQUAL_TIME" 'BEGIN { n = int(b * 16 / (t > 0 ? t : 0.001) + 0.5); print (n < 1 ? 1 : n) }')
    figure f "f-$s" many "$MANY" "$spp" "path:light_selection=$s" "${MANY_ARGS[@]}"
done
BUDGET=""
gallery_reference f many

# ---------------------------------------------------------------- README.md
gallery() {
    local group=$1 n
    n=$(grep -o '!\[' <<<"${GALLERY_IMG[$group]}" | wc -l)
    echo
    echo "${GALLERY_IMG[$group]}"
    printf '|'
    for ((i = 0; i < n; i++)); do printf '%s' '---|'; done
    echo
    echo "${GALLERY_CAP[$group]}"
}

{
    cat <<'EOF'
# Path-tracing lecture: figures

Generated by [`examples/lecture.sh`](../../examples/lecture.sh); do not edit
by hand. Re-run the script to regenerate everything here.

Each figure is compared with a converged render of the same scene (the
`path` integrator with MIS at high spp and another seed; cached, not
committed) by `penumbra diff`:
relMSE = mean over pixels and channels of (a − b)² / (b² + 0.01), b the
reference. Times are the renders' own (load and write excluded) and vary
from run to run on a busy machine. The reference's own noise adds to every
relMSE about what the reference's estimator would show at its spp: for an
unbiased figure rendered with the same estimator, relMSE × spp / reference spp. Scenes: [`examples/`](../../examples) and
[`tests/scenes/many_lights.xml`](../../tests/scenes/many_lights.xml), 128x128.

EOF
    echo "Machine: $(nproc) cores, renders with ${THREADS:-all of them}."
    echo
    echo "| figure | settings | spp | time s | relMSE |"
    echo "|---|---|---|---|---|"
    printf '%s\n' "${ROWS[@]}"
    cat <<'EOF'

## a. Brute force

The hemisphere form of the rendering equation alone
(`bruteforce:sampling=cosine`): one cosine-distributed direction per bounce,
radiance only when a path happens to hit the small light. Unbiased, but the
noise falls only as 1/spp (relMSE, not its root).
EOF
    gallery a
    cat <<'EOF'

## b. Light sampling: number of shadow rays

Direct lighting from one large area light (`direct:emitter_samples=N,bsdf_samples=0`,
1 spp): N points on the light, one shadow ray each. Soft shadows need many
shadow rays; at 1 spp the pixel footprint is still sampled once, so edges
stay aliased whatever N and relMSE stops falling as 1/N.
EOF
    gallery b
    cat <<'EOF'

## c. Number of bounces

`path` with `max_depth` 2 (direct light only), 3 (one indirect bounce) and
6 (five bounces), equal spp, against the full (unbounded) global
illumination: the relMSE of the shallow images is mostly bias, the light
they leave out.
EOF
    gallery c
    cat <<'EOF'

## d. Hemisphere sampling: uniform, cosine, BSDF

`bruteforce` with directions drawn uniformly over the hemisphere
(p = 1/2π), cosine-weighted (p = cos θ/π) or by the BSDF, equal spp. For a
Lambertian BSDF, BSDF sampling *is* cosine sampling, so the last two agree.
EOF
    gallery d
    cat <<'EOF'

## e. Environment map lighting

The scene is lit by an environment map whose light comes mostly from a
small, bright sun. Brute force (cosine) finds the sun by chance; `path`
samples the map by brightness; without MIS (`mis=false`) emitted light is
taken only from light samples, with MIS from both strategies weighted.
EOF
    gallery e
    cat <<'EOF'

## f. Light selection with many lights, equal time

100 small area lights of different powers. `uniform` picks each light with
probability 1/100, `power` in proportion to its emitted power, and `bvh`
(if the renderer has it) by a light tree that also weighs distance and
orientation. Each strategy gets the same time budget: the script measures
its time per sample with a short run, picks the spp that fills the budget
(and corrects it once if the render misses by more than 15 %).
relMSE × time compares efficiency (lower is better).
EOF
    gallery f
    if [ ${#WARNINGS[@]} -gt 0 ]; then
        echo
        echo "## Warnings"
        echo
        printf -- '- %s\n' "${WARNINGS[@]}"
    fi
} >"$STAGE/README.md"

# Replace docs/lecture/ with what this run made.
mkdir -p "$OUT"
rm -f "$OUT"/*.png "$OUT/README.md"
cp "$STAGE"/*.png "$STAGE/README.md" "$OUT/"
echo "== wrote $OUT/README.md and $(ls "$STAGE"/*.png | wc -l) images ($(du -ch "$OUT"/*.png | tail -1 | cut -f1)) in ${SECONDS} s"
