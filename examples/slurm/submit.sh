#!/bin/bash
# Submits a Penumbra render as a Slurm job array of PARTS parts plus a merge
# job that runs once every part has succeeded. Prints the two job IDs.
#
#   SCENE=$PWD/scenes/cornell-box.xml OUTDIR=/shared/renders/box PARTS=8 \
#   PENUMBRA_ARGS="--spp 1024 --seed 1" examples/slurm/submit.sh [sbatch options...]
#
# sbatch options (e.g. -p PARTITION, -c CPUS, --chdir DIR) go to both jobs.
# PENUMBRA: the binary (default: penumbra on PATH); CHECKPOINT_EVERY: seconds (300).
set -euo pipefail
D=$(cd "$(dirname "$0")" && pwd)
: "${SCENE:?set SCENE to the scene file}"
: "${OUTDIR:?set OUTDIR to a directory every node sees}"
export PARTS=${PARTS:-4}
ARRAY=$(sbatch --parsable --array=0-$((PARTS - 1)) "$@" "$D/render.sbatch" | cut -d';' -f1)
MERGE=$(sbatch --parsable --dependency=afterok:"$ARRAY" --kill-on-invalid-dep=yes "$@" "$D/merge.sbatch" | cut -d';' -f1)
echo "$ARRAY $MERGE"
