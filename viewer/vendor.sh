#!/bin/sh
# Regenerates viewer/vendor/ from the three.js package pinned in package.json / package-lock.json.
# Needs node + npm and network access to the npm registry; the result is committed, so building
# and running fragsimd never needs either.
set -eu
cd "$(dirname "$0")"

npm ci --no-audit --no-fund --ignore-scripts

src=node_modules/three
version=$(node -p "require('./$src/package.json').version")
integrity=$(node -p "require('./package-lock.json').packages['node_modules/three'].integrity")

mkdir -p vendor
# three >= 0.17x ships no minified module build: build/three.module.js imports './three.core.js'.
cp "$src/build/three.module.js" vendor/three.module.js
cp "$src/build/three.core.js" vendor/three.core.js
# OrbitControls imports the bare specifier 'three'; without an import map (the CSP forbids inline
# scripts) the browser cannot resolve it, so point it at the vendored file.
sed "s#from 'three';#from './three.module.js';#" \
    "$src/examples/jsm/controls/OrbitControls.js" > vendor/OrbitControls.js
if grep -q "from 'three'" vendor/OrbitControls.js; then
  echo "vendor.sh: OrbitControls.js still imports 'three'" >&2
  exit 1
fi
cp "$src/LICENSE" vendor/LICENSE-three.txt

cat > vendor/README.md <<EOT
# Vendored third-party code

| file | from | licence |
|---|---|---|
| \`three.module.js\`, \`three.core.js\` | npm package \`three\` $version, \`build/\` (unmodified) | MIT (\`LICENSE-three.txt\`) |
| \`OrbitControls.js\` | npm package \`three\` $version, \`examples/jsm/controls/OrbitControls.js\`; its \`from 'three'\` import rewritten to \`from './three.module.js'\` | MIT (\`LICENSE-three.txt\`) |

- Version: three $version (pinned exactly in \`viewer/package.json\`).
- npm integrity of the tarball (from \`viewer/package-lock.json\`): \`$integrity\`
- three $version publishes no minified module build (\`three.module.min.js\`); the unminified
  ES module build is served as is.
- Regenerate: \`viewer/vendor.sh\` (runs \`npm ci\` in \`viewer/\`, then copies and rewrites the
  files above). To upgrade, change the version in \`package.json\`, run
  \`npm install --package-lock-only\`, then \`./vendor.sh\`, and check the viewer.
- The files are committed so that fragsimd builds and serves the viewer without network access.
EOT
echo "vendored three $version into $(pwd)/vendor"
