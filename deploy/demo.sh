#!/usr/bin/env bash
# Quick start, command 1: build (installing dependencies if missing) and run the bundled demo site.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/deploy/build.sh"
cd "$root"
./build/cli/fragsim run examples/demo/scenario.json --out out/demo
echo "results: out/demo/summary.json, out/demo/results.h5"
