#!/usr/bin/env bash
# Quick start, command 1: build (installing dependencies if missing), start fragsimd with a data
# directory under out/, upload the bundled demo site, submit the demo job, follow it, print its
# summary, download its results and maps (out/demo/, out/demo/maps/), write the study report
# (out/demo/report.html, and report.pdf with chromium), and stop the daemon.
# With --keep-running the daemon stays up afterwards, serving the web viewer (docs/viewer.md) at
# the printed URL until `kill $(cat out/fragsimd/pid)`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
keep_running=false
for arg in "$@"; do
  case "$arg" in
    --keep-running) keep_running=true ;;
    *) echo "usage: deploy/demo.sh [--keep-running]" >&2; exit 2 ;;
  esac
done
# Only what the demo runs: the tests and benchmarks are built by deploy/test.sh.
"$root/deploy/build.sh" --target fragsim --target fragsimd
cd "$root"

data="out/fragsimd"
mkdir -p "$data"
# A bearer token for this demo (the daemon always authenticates unless told otherwise).
if [ ! -s "$data/tokens" ]; then
  (umask 077 && od -An -tx1 -N24 /dev/urandom | tr -d ' \n' > "$data/tokens" && echo >> "$data/tokens")
fi
rm -f "$data/port"
if [ -s "$data/pid" ] && kill -0 "$(cat "$data/pid")" 2> /dev/null; then
  echo "stopping the daemon a previous demo --keep-running left (pid $(cat "$data/pid"))"
  kill -TERM "$(cat "$data/pid")" || true
  while kill -0 "$(cat "$data/pid")" 2> /dev/null; do sleep 0.1; done
fi

./build/server/fragsimd --listen 127.0.0.1:0 --data-dir "$data" --token-file "$data/tokens" \
  --port-file "$data/port" > "$data/fragsimd.log" 2>&1 &
daemon=$!
echo "$daemon" > "$data/pid"
stop_daemon() {
  if kill -0 "$daemon" 2> /dev/null; then
    kill -TERM "$daemon" && wait "$daemon" || true
  fi
}
trap stop_daemon EXIT

for _ in $(seq 1 100); do
  [ -s "$data/port" ] && break
  kill -0 "$daemon" 2> /dev/null || { cat "$data/fragsimd.log" >&2; exit 1; }
  sleep 0.1
done
[ -s "$data/port" ] || { echo "fragsimd did not start; log: $data/fragsimd.log" >&2; exit 1; }
url="http://127.0.0.1:$(cat "$data/port")"
echo "fragsimd listening on $url (log: $data/fragsimd.log)"

# --maps: the job's maps from the daemon (GET /v1/jobs/{id}/maps; the files `fragsim export`
# writes): PTN density GeoTIFFs, hazardous area, buildings and HFD as GeoPackage, GeoJSON, KML
# (docs/gis.md, "Outputs").
./build/cli/fragsim submit examples/demo/scenario.json --server "$url" \
  --token-file "$data/tokens" --out out/demo --maps
echo "results: out/demo/summary.json, out/demo/results.h5 (daemon data: $data); maps:"
printf '  %s\n' out/demo/maps/*
# The study report (docs/report.md): one self-contained HTML page, and its PDF when Debian's
# chromium is installed (deploy/install-deps.sh installs it with the test dependencies).
if [ -x "${CHROMIUM:-/usr/bin/chromium}" ]; then
  ./build/cli/fragsim report out/demo/results.h5 --out out/demo/report.html --pdf out/demo/report.pdf
else
  ./build/cli/fragsim report out/demo/results.h5 --out out/demo/report.html
  echo "no chromium: the PDF of the report was not printed (apt-get install chromium)"
fi
if $keep_running; then
  trap - EXIT
  echo "web viewer: $url/ui/  (token: the line in $data/tokens; the page asks for it once)"
  echo "fragsimd keeps running (pid $daemon); stop it with: kill \$(cat $data/pid)"
else
  stop_daemon
  echo "web viewer: ./deploy/demo.sh --keep-running leaves the daemon up and prints the page's URL"
fi
