#!/usr/bin/env bash
# Installs the Debian 12 packages fragsim builds and tests with, only when one is missing.
# Safe to run repeatedly; needs root (or sudo) only when something has to be installed.
set -euo pipefail
PACKAGES=(
  build-essential cmake pkg-config git
  libeigen3-dev            # linear algebra (vectors, quaternions, inertia tensors)
  libembree-dev            # Embree 3.13.x ray queries against terrain and building meshes
  libcpp-httplib-dev       # HTTP server for fragsimd
  zlib1g-dev               # gzip of fragsimd's text answers (server/compression.h)
  nlohmann-json3-dev       # JSON contract
  libsqlite3-dev sqlite3   # job queue and result index (fragsimd)
  libhdf5-dev              # results.h5
  librandom123-dev         # Philox counter-based random streams
  libgtest-dev libgmock-dev googletest  # unit and validation tests
  libopenmpi-dev openmpi-bin  # fragsim-mpi: a run divided among MPI ranks (mpi/, docs/cluster.md)
  libbenchmark-dev         # micro-benchmarks in bench/
  libgdal-dev gdal-bin     # gis/: DEM and footprint import (GDAL/OGR 3.6, PROJ 9)
  clang llvm libclang-rt-14-dev  # sanitizer builds and libFuzzer (deploy/sanitize.sh, fuzz.sh)
  clang-format-14          # the formatting check of CI (deploy/check-format.sh)
  python3-vtk9             # tests: VTK's own reader checks the ParaView (VTKHDF) export
  hdf5-tools               # h5dump: bench/time_to_precision.py reads the PTN grid of results.h5
  chromium                 # tests: the web viewer in headless Chromium (viewer/test/, docs/viewer.md)
  slurm-wlm munge iproute2 # tests: sharded runs on a private single-node Slurm (deploy/cluster/; ss finds free ports)
  python3-yaml             # tests: the Kubernetes Job manifests of deploy/cluster/k8s/ are read; the OpenAPI document
  python3-jsonschema       # tests: fragsimd's answers validated against its OpenAPI document (tests/server/contract_test.py)
  python3-numpy python3-h5py python3-pandas  # the Python client (python/, docs/python.md): numpy required, h5py reads results.h5, pandas its DataFrames; tests: ctest python_client under /usr/bin/python3
  python3-pip python3-venv python3-setuptools  # tests: the client's offline `pip install ./python` into a temporary venv
)
# Node.js and npm run the viewer's browser tests (playwright-core from the npm registry, pinned in
# viewer/test/package-lock.json) and the OpenAPI document's checks (validator, openapi-typescript,
# typescript, pinned in tests/server/openapi/package-lock.json). Debian's packages only when no node/npm is on the PATH: a
# machine with its own Node.js (e.g. NodeSource's, which bundles npm) keeps it.
if ! command -v node > /dev/null || ! command -v npm > /dev/null; then
  PACKAGES+=(nodejs npm)
fi
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
