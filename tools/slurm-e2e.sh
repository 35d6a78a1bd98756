#!/usr/bin/env bash
# End-to-end test of `penumbra render --part auto` + `penumbra merge` on a real
# single-node Slurm cluster (Debian's slurmctld/slurmd 22.05 and munge),
# started in a temporary directory and stopped again (by PID) on exit.
#
#   tools/slurm-e2e.sh            # installs slurm + munge with apt-get if missing (needs root)
#
# What it does (recipe and pitfalls: the project's shared slurm-notes.md):
#  1. starts munged, slurmctld and slurmd in a mktemp directory, on free ports;
#  2. renders the scene once on this machine (the reference);
#  3. submits a job array of 4 parts (`--part auto`, `--requeue`, `--checkpoint`
#     on the shared output directory) and a merge job with
#     `--dependency=afterok:<array> --kill-on-invalid-dep=yes`, polls
#     `scontrol show job -o` until they end, and checks that the merged EXR
#     equals the reference (largest relative difference <= 1e-6);
#  4. submits a second array in which part 2 fails (its scene file is missing),
#     checks that the merge job is cancelled (DependencyNeverSatisfied), reruns
#     part 2 alone with `--part 2/4`, merges, and compares again;
#  5. cancels everything, then stops slurmd, slurmctld and munged by PID.
# Exits non-zero, with the reason and the daemons' log tails, on any failure.
#
# Environment: PENUMBRA_BIN (default: the release binary, built if needed),
# SLURM_E2E_KEEP=1 keeps the temporary directory.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
now() { echo "$EPOCHREALTIME"; }
# Seconds from $2 to $1, two decimals.
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a - b }'; }
T_START=$(now)
SCENE=$ROOT/scenes/cornell-box.xml
RENDER_ARGS=(-D res=64 -D spp=16 --seed 7)
PARTS=4

say() { printf '[slurm-e2e %6ss] %s\n' "$(secs "$(now)" "$T_START")" "$*"; }
die() {
    echo "slurm-e2e: FAILED: $*" >&2
    if [ -n "${W:-}" ] && [ -d "$W/log" ]; then
        for f in "$W"/log/* "$W"/munge/munged.log "$W"/out*/*.log; do
            [ -f "$f" ] && { echo "--- tail of $f" >&2; tail -n 15 "$f" >&2; }
        done
    fi
    exit 1
}

# --- the release binary ---------------------------------------------------------
if [ -n "${PENUMBRA_BIN:-}" ]; then
    BIN=$PENUMBRA_BIN
else
    BIN=${CARGO_TARGET_DIR:-$ROOT/target}/release/penumbra
    if command -v cargo >/dev/null; then
        say "cargo build --release -p penumbra"
        (cd "$ROOT" && cargo build --release -p penumbra --quiet) || die "cargo build --release failed"
    fi
fi
[ -x "$BIN" ] || die "no penumbra binary at $BIN (build it with cargo build --release, or set PENUMBRA_BIN)"
case $BIN in /*) ;; *) BIN=$PWD/$BIN ;; esac

# --- install Slurm and MUNGE if missing -----------------------------------------
T_INSTALL=0
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null \
    || ! command -v munged >/dev/null || ! command -v mungekey >/dev/null; then
    [ "$(id -u)" = 0 ] || die "Slurm is not installed and this is not root: apt-get install slurmctld slurmd slurm-client munge"
    say "installing slurmctld slurmd slurm-client munge (apt-get, --no-install-recommends)"
    t0=$(now)
    # No systemd here: keep the packages' postinst from starting system daemons.
    MADE_POLICY=
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
        MADE_POLICY=1
    fi
    export DEBIAN_FRONTEND=noninteractive
    ok=1
    apt-get update -qq || ok=
    [ -n "$ok" ] && { apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null || ok=; }
    [ -n "$MADE_POLICY" ] && rm -f /usr/sbin/policy-rc.d
    [ -n "$ok" ] || die "apt-get install slurmctld slurmd slurm-client munge failed"
    T_INSTALL=$(secs "$(now)" "$t0")
    say "installed in ${T_INSTALL} s"
fi

# --- a temporary cluster ---------------------------------------------------------
W=$(mktemp -d /tmp/penumbra-slurm.XXXXXX)
chmod 755 "$W" # munged refuses a socket directory that others cannot traverse
mkdir -p "$W"/{munge,state,spool,log,run,out,out2}
chmod 755 "$W/munge"
PIDS=() # started daemons, in start order

stop_all() {
    local rc=$?
    set +e
    if [ -n "${SLURM_CONF:-}" ] && [ -n "${PID_CTLD:-}" ] && kill -0 "$PID_CTLD" 2>/dev/null; then
        scancel --user="$(id -un)" 2>/dev/null
        # Wait (at most 15 s) until no job is left and the node is idle again
        # (a node stays "completing" until the jobs' slurmstepd have ended).
        for _ in $(seq 75); do
            [ -z "$(squeue -h 2>/dev/null)" ] && [ "$(sinfo -h -N -o %T 2>/dev/null)" = idle ] && break
            sleep 0.2
        done
    fi
    # Stop in reverse order: slurmd, slurmctld, munged; each by its PID.
    for ((i = ${#PIDS[@]} - 1; i >= 0; i--)); do
        kill -TERM "${PIDS[i]}" 2>/dev/null
        wait "${PIDS[i]}" 2>/dev/null
    done
    if [ "${SLURM_E2E_KEEP:-}" = 1 ] || [ $rc != 0 ]; then
        echo "slurm-e2e: kept $W" >&2
    else
        rm -rf "$W"
    fi
    exit $rc
}
trap stop_all EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# A free pair of ports (not in LISTEN state in /proc/net/tcp{,6}).
listening() {
    local f sl local_addr rem st rest
    for f in /proc/net/tcp /proc/net/tcp6; do
        [ -r "$f" ] || continue
        while read -r sl local_addr rem st rest; do
            [ "$st" = 0A ] && echo $((16#${local_addr##*:}))
        done < <(tail -n +2 "$f")
    done
}
USED=" $(listening | tr '\n' ' ') "
PORT=
for p in $(seq 6817 2 6999); do
    case $USED in *" $p "* | *" $((p + 1)) "*) continue ;; esac
    PORT=$p
    break
done
[ -n "$PORT" ] || die "no free port pair in 6817-7000"

mungekey --create --keyfile="$W/munge/munge.key" >/dev/null 2>&1 || die "mungekey --create failed"
munged -F --socket="$W/munge/munge.socket" --key-file="$W/munge/munge.key" \
    --pid-file="$W/munge/munged.pid" --log-file="$W/munge/munged.log" \
    --seed-file="$W/munge/munged.seed" >"$W/log/munged.out" 2>&1 &
PID_MUNGED=$!
PIDS+=("$PID_MUNGED")

NODE=$(slurmd -C | head -n 1 | sed 's/^NodeName=[^ ]*/NodeName=localhost/')
case $NODE in NodeName=localhost*CPUs=*) ;; *) die "slurmd -C printed '$NODE'" ;; esac
cat >"$W/slurm.conf" <<EOF
ClusterName=penumbra-ci
SlurmctldHost=localhost
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$W/munge/munge.socket
StateSaveLocation=$W/state
SlurmdSpoolDir=$W/spool
SlurmctldPidFile=$W/run/slurmctld.pid
SlurmdPidFile=$W/run/slurmd.pid
SlurmctldLogFile=$W/log/slurmctld.log
SlurmdLogFile=$W/log/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=600
KillWait=5
$NODE State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$W/slurm.conf

for _ in $(seq 50); do [ -S "$W/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$W/munge/munge.socket" ] || die "munged did not create its socket"
T_CLUSTER=$(now)
slurmctld -D -f "$SLURM_CONF" >"$W/log/slurmctld.out" 2>&1 &
PID_CTLD=$!
PIDS+=("$PID_CTLD")
slurmd -D -f "$SLURM_CONF" -N localhost >"$W/log/slurmd.out" 2>&1 &
PID_SLURMD=$!
PIDS+=("$PID_SLURMD")
for _ in $(seq 150); do
    [ "$(sinfo -h -N -o %T 2>/dev/null)" = idle ] && break
    kill -0 "$PID_CTLD" 2>/dev/null || die "slurmctld exited"
    kill -0 "$PID_SLURMD" 2>/dev/null || die "slurmd exited"
    sleep 0.2
done
[ "$(sinfo -h -N -o %T)" = idle ] || die "the node is not idle after 30 s: $(sinfo -N 2>&1)"
say "cluster up (ports $PORT/$((PORT + 1)), $W) in $(secs "$(now)" "$T_CLUSTER") s"

# --- the reference: one machine, all samples ----------------------------------------
"$BIN" render "$SCENE" -o "$W/single.exr" "${RENDER_ARGS[@]}" --quiet || die "the single-machine render failed"
say "single-machine render done"

# --- the job scripts: the shipped examples ------------------------------------------
# examples/slurm/{submit.sh,render.sbatch,merge.sbatch}: an array of parts
# (`--part auto`, `--requeue`, a checkpoint per part beside it in $OUTDIR)
# and a merge job with `--dependency=afterok:<array> --kill-on-invalid-dep=yes`.
EX=$ROOT/examples/slurm
export PENUMBRA=$BIN SCENE PARTS PENUMBRA_ARGS="${RENDER_ARGS[*]}" CHECKPOINT_EVERY=60
# -c 1: the parts share the 2-CPU node two at a time (penumbra uses SLURM_CPUS_PER_TASK threads).
SB=(-c 1)

# Field of a `scontrol show job -o` line.
field() { sed -n "s/.* $1=\([^ ]*\).*/\1/p"; }
# Waits until every task of job $1 has ended; prints one "JobState Reason ExitCode" line per task.
wait_job() {
    local id=$1 deadline=$(($(date +%s) + ${2:-120})) out
    while :; do
        out=$(scontrol show job -o "$id" 2>&1) || die "scontrol show job $id: $out"
        # (A job whose dependency failed stays PENDING forever unless it was
        # submitted with --kill-on-invalid-dep=yes: then the deadline fails the test.)
        if ! echo "$out" | grep -Eq 'JobState=(PENDING|RUNNING|CONFIGURING|COMPLETING|REQUEUED|RESIZING|SUSPENDED)'; then
            echo "$out" | while read -r l; do
                echo "$(echo "$l" | field JobState) $(echo "$l" | field Reason) $(echo "$l" | field ExitCode) $(echo "$l" | field ArrayTaskId)"
            done
            return
        fi
        [ "$(date +%s)" -lt "$deadline" ] || die "job $id did not end in ${2:-120} s: $out"
        sleep 0.2
    done
}
all_completed() { ! echo "$1" | grep -qv '^COMPLETED '; }
compare() {
    local merged=$1 out
    out=$("$BIN" diff "$merged" "$W/single.exr" --max-rel 1e-6) || die "merged image differs from the single-machine render: $out"
    say "$(echo "$out" | grep 'max rel')"
}
submit() { sbatch --parsable "$@" | cut -d';' -f1; }

# --- run 1: 4 parts and the merge ----------------------------------------------------
T_JOBS=$(now)
export OUTDIR=$W/out
read -r ARRAY MERGE < <("$EX/submit.sh" "${SB[@]}" --chdir="$OUTDIR") || die "submit.sh failed"
[ -n "$MERGE" ] || die "submit.sh did not print two job IDs"
say "submitted array $ARRAY ($PARTS parts) and merge job $MERGE (afterok:$ARRAY)"
s=$(wait_job "$ARRAY") && all_completed "$s" || die "array $ARRAY: $s"
s=$(wait_job "$MERGE") && all_completed "$s" || die "merge job $MERGE: $s"
T_RUN1=$(secs "$(now)" "$T_JOBS")
say "array and merge COMPLETED in $T_RUN1 s (submit to merged EXR)"
compare "$OUTDIR/merged.exr"

# --- run 2: part 2 fails; the merge is cancelled; part 2 rerun alone ------------------------
export OUTDIR=$W/out2
mkdir "$OUTDIR/part2.exr" # a directory where part 2's image goes: its write fails
read -r ARRAY MERGE < <("$EX/submit.sh" "${SB[@]}" --chdir="$OUTDIR") || die "submit.sh failed"
say "submitted array $ARRAY with part 2 bound to fail, and merge job $MERGE"
s=$(wait_job "$ARRAY")
for i in 0 1 3; do echo "$s" | grep -q "^COMPLETED .* $i\$" || die "array $ARRAY: part $i did not complete: $s"; done
echo "$s" | grep -q '^FAILED NonZeroExitCode [1-9][0-9]*:0 2$' || die "array $ARRAY: part 2 should have failed: $s"
s=$(wait_job "$MERGE" 30)
case $s in CANCELLED\ DependencyNeverSatisfied*) ;; *) die "merge job $MERGE should be cancelled: $s" ;; esac
[ ! -e "$OUTDIR/merged.exr" ] || die "a merged image exists though part 2 failed"
say "part 2 FAILED ($(grep -h -m1 -i 'error' "$OUTDIR"/penumbra-parts-*_2.log | head -c 150)); merge job $MERGE CANCELLED (DependencyNeverSatisfied)"
rmdir "$OUTDIR/part2.exr"
# The rerun, as the README shows it: sbatch --array=2 --export=ALL,PART=2/4 render.sbatch
RERUN=$(submit --array=2 --export=ALL,PART=2/$PARTS "${SB[@]}" --chdir="$OUTDIR" "$EX/render.sbatch") \
    || die "sbatch of the rerun failed"
MERGE=$(submit --dependency=afterok:"$RERUN" --kill-on-invalid-dep=yes "${SB[@]}" --chdir="$OUTDIR" "$EX/merge.sbatch") \
    || die "sbatch of the merge job failed"
s=$(wait_job "$RERUN") && all_completed "$s" || die "rerun of part 2 ($RERUN): $s"
s=$(wait_job "$MERGE") && all_completed "$s" || die "merge job $MERGE: $s"
say "part 2 rerun alone (--part 2/$PARTS, job $RERUN) and merged (job $MERGE)"
compare "$OUTDIR/merged.exr"
for i in 0 1 2 3; do [ ! -e "$W/out/part$i.ck" ] && [ ! -e "$W/out2/part$i.ck" ] || die "checkpoint part$i.ck left behind"; done

T_END=$(now)
say "PASSED: end to end $(secs "$T_END" "$T_START") s (install ${T_INSTALL} s; cluster start to last check $(secs "$T_END" "$T_CLUSTER") s; run 1 submit to merged EXR $T_RUN1 s)"
