#!/usr/bin/env bash
# Runs ctest (its arguments passed on) in the current directory with TMPDIR pointing at a scratch
# directory of its own, removed when every test passed and kept (path printed) when one failed.
# The daemon tests write results of up to 300 MB each; without this a CI run's three suites
# (deploy/test.sh, ASan, TSan) left gigabytes in /tmp and filled the disk (stop 33).
set -euo pipefail
scratch="$(mktemp -d "${TMPDIR:-/tmp}/fragsim-ctest.XXXXXX")"
# Searchable by all (not listable): the private Slurm's munged refuses a socket below a directory
# others cannot enter (deploy/cluster/slurm-local.sh).
chmod 0711 "$scratch"
status=0
TMPDIR="$scratch" ctest "$@" || status=$?
if [ "$status" -eq 0 ]; then
  rm -rf "$scratch"
else
  echo "ctest-scratch: a test failed; its temporary files are kept in $scratch" >&2
fi
exit "$status"
