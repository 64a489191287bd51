#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds fragsim (Release) into ./build.
#   deploy/build.sh                                # every target (tests and benchmarks included)
#   deploy/build.sh --target fragsim --target fragsimd   # only these (deploy/demo.sh does this)
# Other arguments go to cmake's configure step (e.g. -DFRAGSIM_WERROR=ON).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
targets=()
configure=()
while [ $# -gt 0 ]; do
  case "$1" in
    --target)
      [ $# -ge 2 ] || { echo "build.sh: --target needs a target name" >&2; exit 2; }
      targets+=(--target "$2")
      shift 2
      ;;
    *) configure+=("$1"); shift ;;
  esac
done
"$root/deploy/install-deps.sh"
jobs="$(nproc 2>/dev/null || echo 2)"
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release "${configure[@]}" >/dev/null
cmake --build "$root/build" -j "$jobs" "${targets[@]}"
