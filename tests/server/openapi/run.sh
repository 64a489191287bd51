#!/usr/bin/env bash
# The served OpenAPI document checked by standard tools, as a front end's build would use it:
#   1. it validates as OpenAPI 3.1 (@seriousme/openapi-schema-validator) and every $ref resolves;
#   2. openapi-typescript generates TypeScript types from it, and client.ts, which uses them
#      (a job request with the scenario's own types, a job status, a summary, an error),
#      type-checks with tsc --strict.
#
#   tests/server/openapi/run.sh OPENAPI.yaml      (ctest: openapi_document, with build/generated/openapi.yaml)
#
# Needs node >= 18 and npm (the npm registry, once: the versions pinned in package-lock.json are
# installed into node_modules/ with npm ci).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
doc="${1:?usage: run.sh OPENAPI.yaml}"
fail() { echo "openapi checks: $*" >&2; exit 1; }
command -v node >/dev/null || fail "node not found: apt-get install nodejs npm (node >= 18)"
[ -f "$doc" ] || fail "no document at $doc (configure the build: cmake -S . -B build)"

# The pinned tools, installed once (npm ci) and again only when package-lock.json changes.
lock="$here/package-lock.json"
stamp="$here/node_modules/.fragsim-lock.sha256"
want="$(sha256sum "$lock" | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
  command -v npm >/dev/null || fail "npm not found: apt-get install npm"
  echo "openapi checks: installing the pinned validator, openapi-typescript and typescript (npm ci)" >&2
  (cd "$here" && npm ci --no-audit --no-fund --loglevel=error) || fail "npm ci failed in $here (is the npm registry reachable?)"
  echo "$want" > "$stamp"
fi

node "$here/check.mjs" "$doc"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp "$here/client.ts" "$here/tsconfig.json" "$work/"
# --default-non-nullable false: a key with a default stays optional in a request body.
"$here/node_modules/.bin/openapi-typescript" "$doc" --default-non-nullable false \
  -o "$work/fragsimd.d.ts" --silent
"$here/node_modules/.bin/tsc" -p "$work/tsconfig.json" || fail "client.ts does not type-check against the generated types"
echo "openapi checks: the document is valid and a TypeScript client type-checks against it" >&2
