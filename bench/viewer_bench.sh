#!/usr/bin/env bash
# Browser benchmark of the web viewer (see the header of bench/viewer_bench.mjs):
#   bench/viewer_bench.sh [--runs 3] [--frames 120] [--cases demo,large] [--out FILE]
# Installs viewer/test's pinned playwright-core if missing; needs chromium (apt-get install
# chromium) and a built fragsimd (env FRAGSIMD, default build/server/fragsimd).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ -x "${CHROMIUM:-/usr/bin/chromium}" ] || { echo "viewer_bench: chromium missing: apt-get install chromium" >&2; exit 1; }
if [ ! -f "$repo/viewer/test/node_modules/playwright-core/package.json" ]; then
  (cd "$repo/viewer/test" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
fi
exec node "$repo/bench/viewer_bench.mjs" "$@"
