#!/bin/sh
# Regenerates report/assets/vendor/ from the packages pinned in package.json / package-lock.json:
# Observable Plot draws the study report's figures (SVG), on top of d3. Needs node + npm and the
# npm registry; the result is committed, so building fragsim and writing a report never need
# either (docs/report.md, "Figures").
set -eu
cd "$(dirname "$0")"

npm ci --no-audit --no-fund --ignore-scripts

integrity() {
  node -p "require('./package-lock.json').packages['node_modules/$1'].integrity"
}
version() {
  node -p "require('./node_modules/$1/package.json').version"
}

mkdir -p vendor
cp node_modules/d3/dist/d3.min.js vendor/d3.min.js
cp node_modules/@observablehq/plot/dist/plot.umd.min.js vendor/plot.umd.min.js
cp node_modules/d3/LICENSE vendor/LICENSE-d3.txt
cp node_modules/@observablehq/plot/LICENSE vendor/LICENSE-plot.txt

cat > vendor/README.md <<EOT
# Vendored third-party code (inlined into every study report)

| file | from | licence |
|---|---|---|
| \`d3.min.js\` | npm package \`d3\` $(version d3), \`dist/\` (unmodified) | ISC (\`LICENSE-d3.txt\`) |
| \`plot.umd.min.js\` | npm package \`@observablehq/plot\` $(version @observablehq/plot), \`dist/\` (unmodified) | ISC (\`LICENSE-plot.txt\`) |

- npm integrity (from \`package-lock.json\`): d3 \`$(integrity d3)\`;
  @observablehq/plot \`$(integrity @observablehq/plot)\`.
- Regenerate: \`report/assets/vendor.sh\`. To upgrade, change a version in \`package.json\`, run
  \`npm install --package-lock-only\`, then \`./vendor.sh\`, and check a report.
- Committed so that fragsim writes reports without network access.
EOT
echo "vendored d3 $(version d3) and @observablehq/plot $(version @observablehq/plot) into $(pwd)/vendor"
