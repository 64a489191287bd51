#!/usr/bin/env bash
# Regenerates the regression baselines, tests/regression/baselines/<name>.json, from runs of the
# current code (docs/testing.md, "Regression baselines"). Only after an intended physics change:
# then review `git diff tests/regression/baselines` and say in the commit why the figures moved.
#
#   deploy/regen-baselines.sh                  all scenarios
#   deploy/regen-baselines.sh demo minimal     some (names: deploy/regen-baselines.sh --list)
#   deploy/regen-baselines.sh --calibrate 10   10 other seeds per scenario against the stored
#                                              seed, compared as the test compares; writes nothing
#
# Builds the regen_baselines tool (Release) in $FRAGSIM_BUILD_DIR (default: build/), configuring
# it first if needed. Before overwriting a baseline the tool prints every figure that moved
# beyond the test's tolerance against it.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${FRAGSIM_BUILD_DIR:-$root/build}"
case "$build" in /*) ;; *) build="$root/$build" ;; esac
jobs="$(nproc 2>/dev/null || echo 2)"

if [ ! -f "$build/CMakeCache.txt" ]; then
  "$root/deploy/install-deps.sh"
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
cmake --build "$build" -j "$jobs" --target regen_baselines

# Provenance: the commit the figures come from, -dirty when tracked files (other than the
# baselines themselves) differ from it: the usual case when regenerating before committing.
commit="$(git -C "$root" rev-parse --short=12 HEAD 2>/dev/null || echo unknown)"
if [ "$commit" != unknown ] &&
   [ -n "$(git -C "$root" status --porcelain --untracked-files=no -- . ':!tests/regression/baselines')" ]; then
  commit="$commit-dirty"
fi

"$build/tests/regen_baselines" --commit "$commit" "$@"
