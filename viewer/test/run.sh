#!/usr/bin/env bash
# Headless-browser tests of the fragsimd web viewer.
#
#   viewer/test/run.sh [node --test options...]      (from anywhere; also from ctest)
#
# Environment:
#   FRAGSIMD        daemon binary           (default <repo>/build/server/fragsimd)
#   FRAGSIM_CLI     CLI binary              (default <repo>/build/cli/fragsim)
#   SCREENSHOT_DIR  screenshots (artefacts) (default <repo>/out/viewer-test)
#   CHROMIUM        browser                 (default /usr/bin/chromium, Debian package "chromium")
#   FRAGSIM_UI_DIR  serve the page from this folder (fragsimd --ui-dir) instead of the copy
#                   embedded in the binary, e.g. FRAGSIM_UI_DIR=<repo>/viewer while editing it
#   VIEWER_TEST_KEEP=1  keep each daemon's temporary data directory and log
# Needs node >= 18 (Debian 12 ships 18.19) and npm (the npm registry, once, for playwright-core; no browser download).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
export FRAGSIMD="${FRAGSIMD:-$repo/build/server/fragsimd}"
export FRAGSIM_CLI="${FRAGSIM_CLI:-$repo/build/cli/fragsim}"
export SCREENSHOT_DIR="${SCREENSHOT_DIR:-$repo/out/viewer-test}"
export CHROMIUM="${CHROMIUM:-/usr/bin/chromium}"

fail() { echo "viewer tests: $*" >&2; exit 1; }

command -v node >/dev/null || fail "node not found: apt-get install nodejs npm (node >= 18)"
node_major="$(node -p 'process.versions.node.split(".")[0]')"
[ "$node_major" -ge 18 ] || fail "node $(node --version) is too old: node >= 18 is needed (built-in test runner)"
[ -x "$CHROMIUM" ] || fail "chromium not found at $CHROMIUM: apt-get install chromium (or set CHROMIUM)"
[ -x "$FRAGSIMD" ] || fail "fragsimd not found at $FRAGSIMD: build it (cmake --build build -j) or set FRAGSIMD"
if ! "$FRAGSIMD" --help 2>&1 | grep -q -- '--ui-dir'; then
  fail "$FRAGSIMD does not serve the viewer (no --ui-dir in --help): rebuild it (cmake --build build -j)"
fi

# playwright-core, pinned in package-lock.json; installed once (npm ci), never a browser download.
want="$(node -p 'require(process.argv[1]).packages["node_modules/playwright-core"].version' "$here/package-lock.json")"
have="$(node -p 'try { require(process.argv[1]).version } catch { "" }' "$here/node_modules/playwright-core/package.json" 2>/dev/null || true)"
if [ "$want" != "$have" ]; then
  command -v npm >/dev/null || fail "npm not found: apt-get install npm"
  echo "viewer tests: installing playwright-core $want (npm ci)" >&2
  (cd "$here" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error) \
    || fail "npm ci failed in $here (is the npm registry reachable?)"
fi

mkdir -p "$SCREENSHOT_DIR"
echo "viewer tests: fragsimd $FRAGSIMD; chromium $("$CHROMIUM" --version 2>/dev/null | head -1); screenshots in $SCREENSHOT_DIR" >&2
cd "$here"
# One file at a time: the tests time jobs and renderings on a small machine.
set +e
# The environment check and the browser-less checks first, then the rest.
files=(./webgl.test.mjs ./static.test.mjs)
for f in ./*.test.mjs; do case " ${files[*]} " in *" $f "*) ;; *) files+=("$f");; esac; done
for a in "$@"; do case "$a" in *.test.mjs) files=();; esac; done
# One `node --test` per file, so that files never run concurrently, on node 18 (which has no
# --test-concurrency) as on 20.
rc=0
if [ ${#files[@]} -eq 0 ]; then
  node --test --test-reporter=spec "$@" || rc=$?
else
  for f in "${files[@]}"; do
    node --test --test-reporter=spec "$@" "$f" || rc=$?
  done
fi
set -e
if [ $rc -ne 0 ]; then
  echo "viewer tests: FAILED (exit $rc); screenshots in $SCREENSHOT_DIR" >&2
else
  echo "viewer tests: all passed; screenshots in $SCREENSHOT_DIR" >&2
fi
exit $rc
