#!/usr/bin/env bash
# Writes the demo site (examples/demo/scenario.json) as GIS files: terrain.tif (the DEM, EPSG:32611),
# buildings.gpkg (footprints with height and material attributes) and import.json, which
# `fragsim site import` reads back into the same site in absolute UTM coordinates (docs/gis.md).
# The files here were made by this script; tests/gis/site_to_gis_test.cpp checks they still
# match the demo. Run from anywhere after a build.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)"
"$root/build/cli/fragsim" site export-gis "$root/examples/demo/scenario.json" \
  --out "$root/examples/demo/gis"
