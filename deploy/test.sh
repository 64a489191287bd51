#!/usr/bin/env bash
# Quick start, command 2: build (installing dependencies if missing) and run the whole test suite.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
t0=$(date +%s)
"$root/deploy/build.sh"
build_s=$(($(date +%s) - t0))
[ -z "${FRAGSIM_CI_TIMES:-}" ] || echo "  test.sh: install + build ${build_s} s" >>"$FRAGSIM_CI_TIMES"
cd "$root/build"
"$root/deploy/ctest-scratch.sh" --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" --timeout 1200
