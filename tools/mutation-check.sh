#!/usr/bin/env bash
# Mutation check: applies each realistic bug in tools/mutations/*.patch to a
# scratch worktree of HEAD, runs the renderer's and the scene crate's tests
# (closed forms and furnaces, chi-square tests, estimator agreement, Mitsuba
# references) and prints, per bug, the tests that failed. A bug that no test
# catches is reported as such and makes the script exit 1. The unmodified
# tree runs first: it must pass.
#
#   tools/mutation-check.sh [PATCH...]     (default: every tools/mutations/*.patch)
#
# Builds with the `mutation` profile (release without LTO: each bug rebuilds
# only Penumbra's crates) in target/mutation; about 5 minutes a bug on 2 cores.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
patches=("$@")
[ ${#patches[@]} -gt 0 ] || patches=("$repo"/tools/mutations/*.patch)
wt=$(mktemp -d /tmp/penumbra-mutation.XXXXXX)
trap 'git -C "$repo" worktree remove --force "$wt" >/dev/null 2>&1 || true' EXIT
git -C "$repo" worktree add -q --detach "$wt" HEAD
export CARGO_TARGET_DIR="$repo/target/mutation"
run_tests() { # $1: log file
    (cd "$wt" && cargo test --profile mutation -p penumbra-render -p penumbra-scene --no-fail-fast >"$1" 2>&1) || true
    { grep -E '^test .* \.\.\. FAILED$' "$1" || true; } | sed -E 's/^test (.*) \.\.\. FAILED$/\1/' | sort -u
}
logs=$(mktemp -d /tmp/penumbra-mutation-logs.XXXXXX)
echo "baseline (no bug): building and testing"
base=$(run_tests "$logs/baseline.log")
if [ -n "$base" ] || ! grep -q '^test result' "$logs/baseline.log"; then
    echo "the unmodified tree fails (log $logs/baseline.log):" >&2
    echo "$base" >&2
    exit 1
fi
status=0
printf '\n| injected bug | tests that failed |\n|---|---|\n' >"$logs/table.md"
for p in "${patches[@]}"; do
    name=$(basename "$p" .patch)
    (cd "$wt" && git checkout -q . && git apply "$p") || { echo "$name: patch does not apply to HEAD" >&2; status=1; continue; }
    echo "$name: building and testing"
    failed=$(run_tests "$logs/$name.log")
    if ! grep -q '^test result' "$logs/$name.log"; then
        echo "$name: did not build or run (log $logs/$name.log)" >&2
        status=1
        continue
    fi
    if [ -z "$failed" ]; then
        printf '| %s | **none** |\n' "$name" >>"$logs/table.md"
        status=1
    else
        printf '| %s | %s (%d) |\n' "$name" "$(echo "$failed" | paste -sd, - | sed 's/,/, /g')" "$(echo "$failed" | wc -l)" >>"$logs/table.md"
    fi
    (cd "$wt" && git checkout -q .)
done
cat "$logs/table.md"
echo "logs: $logs"
exit $status
