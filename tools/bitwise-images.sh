#!/usr/bin/env bash
# Renders the bundled and test scenes to PFM at a few samples with a fixed
# seed, for bitwise before/after comparisons of refactors:
#   tools/bitwise-images.sh BIN OUTDIR          # render
#   tools/bitwise-images.sh --compare DIR1 DIR2 # cmp every PFM
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = --compare ]; then
    status=0
    for f in "$2"/*.pfm; do
        n=$(basename "$f")
        if cmp -s "$f" "$3/$n"; then echo "same  $n"; else echo "DIFF  $n"; status=1; fi
    done
    exit $status
fi
bin=$1 out=$2
mkdir -p "$out"
for s in scenes/*.xml tests/scenes/*.xml tools/bitwise-scenes/*.xml; do
    n=$(basename "$s" .xml)
    "$bin" render "$s" -o "$out/$n.pfm" --spp 16 --seed 3 --threads 2 --quiet 2>/dev/null
done
# Light selection by power and through the light BVH (scenes use uniform).
for s in many_lights spot_light envmap_sun point_light; do
    for sel in power bvh; do
        "$bin" render "tests/scenes/$s.xml" -o "$out/${s}_$sel.pfm" --spp 16 --seed 3 --threads 2 \
            --integrator "path:light_selection=$sel" --quiet 2>/dev/null
    done
done
