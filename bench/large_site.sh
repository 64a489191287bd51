#!/usr/bin/env bash
# A large DEM through every path: `fragsim site import`, `validate`, `run`, `export`, and
# fragsimd (POST /v1/sites, a job, GET /v1/jobs/{id}/maps). Wall time and peak RSS of each step
# (GNU time), printed as a Markdown table for docs/benchmarks.md section 7.
#
#   bench/large_site.sh N [SAMPLES] [BUILD_DIR]
#
# N: the DEM is N x N cells of 1 m (a flat GeoTIFF made by gdal_create, EPSG:32611; flat or not,
# the sizes are the same), i.e. (N-1)^2 * 2 terrain triangles: N = 1415 gives 4.0 M, 2001 gives
# 8.0 M, 2829 gives 16.0 M. SAMPLES (default 2000) histories of the demo's fragment groups,
# launched from the centre of the site. BUILD_DIR defaults to ./build. Scratch files go to
# ${TMPDIR:-/tmp}/fragsim-large-N (removed at the end unless KEEP=1).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
n="${1:?usage: bench/large_site.sh N [SAMPLES] [BUILD_DIR]}"
samples="${2:-2000}"
build="$(cd "${3:-$root/build}" && pwd)"
fragsim="$build/cli/fragsim"
fragsimd="$build/server/fragsimd"
work="${TMPDIR:-/tmp}/fragsim-large-$n"
rm -rf "$work"
mkdir -p "$work"
cd "$work"
cleanup() {
  [ -z "${daemon:-}" ] || kill "$daemon" 2>/dev/null || true
  [ "${KEEP:-0}" = 1 ] || rm -rf "$work"
}
trap cleanup EXIT

declare -a rows
# step NAME COMMAND...: runs it under GNU time, records "| NAME | wall s | peak MB |" (the peak of
# the command, or of fragsimd since its start once it runs).
step() {
  local name="$1"
  shift
  /usr/bin/time -f "%e %M" -o time.txt "$@" >"step.log" 2>&1 || {
    cat step.log
    echo "large_site: $name failed" >&2
    exit 1
  }
  read -r wall kb <time.txt
  # For a request to the daemon, the daemon's peak so far, not curl's.
  [ -z "${daemon:-}" ] || kb=$(awk '/VmHWM/ {print $2}' "/proc/$daemon/status")
  rows+=("| $name | $wall s | $((kb / 1024)) MB |")
}

x0=500000
y0=3699000
gdal_create -q -of GTiff -ot Float32 -outsize "$n" "$n" -burn 400 -a_srs EPSG:32611 \
  -a_ullr "$x0" "$((y0 + n))" "$((x0 + n))" "$y0" dem.tif
python3 - "$root" "$n" "$samples" "$x0" "$y0" <<'EOF'
import json, sys
root, n, samples, x0, y0 = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
imp = json.load(open(f"{root}/examples/demo/gis/import.json"))
imp.pop("buildings")
imp["terrain"]["path"] = "dem.tif"
imp["materials"] = {"soil": imp["materials"]["soil"]}
json.dump(imp, open("import.json", "w"), indent=1)
sc = json.load(open(f"{root}/examples/demo/scenario.json"))
total = sum(g["samples"] for g in sc["fragment_groups"])
centre = [x0 + n / 2.0, y0 + n / 2.0, 401.5]
for g in sc["fragment_groups"]:
    g["samples"] = max(1, round(g["samples"] * samples / total))
    g["frame"]["origin_m"] = centre
sc["settings"]["threads"] = 2
json.dump(sc, open("job_template.json", "w"))
EOF

step "\`fragsim site import\` (GeoTIFF → site JSON, checked by building it)" \
  "$fragsim" site import import.json --out site.json
python3 - <<'EOF'
import json
sc = json.load(open("job_template.json"))
site = json.load(open("site.json"))
site.pop("schema", None)
sc["site"] = site
json.dump(sc, open("scenario.json", "w"))
EOF
site_mb=$(($(stat -c %s site.json) / 1000000))
step "\`fragsim validate\` (scenario with the site inline)" "$fragsim" validate scenario.json
step "\`fragsim run\`, $samples histories, 2 threads" "$fragsim" run scenario.json --out run
run_line="$(grep -o 'Run time.*' step.log || true)"
step "\`fragsim export\` (GeoTIFFs, GeoPackage, GeoJSON, KML)" "$fragsim" export run/results.h5 --out maps

# The daemon: loopback, no auth, its own data directory.
"$fragsimd" --listen 127.0.0.1:0 --port-file port --data-dir data --no-auth --threads 2 \
  --log-level warn >daemon.log 2>&1 &
daemon=$!
for _ in $(seq 100); do [ -s port ] && break; sleep 0.1; done
url="http://127.0.0.1:$(cat port)"
step "POST /v1/sites (${site_mb} MB of JSON)" \
  curl -sS --fail-with-body -o site_resp.json -H 'Content-Type: application/json' --data-binary @site.json \
  "$url/v1/sites"
site_id="$(python3 -c 'import json; print(json.load(open("site_resp.json"))["site_id"])')"
python3 - "$site_id" <<'EOF'
import json, sys
sc = json.load(open("job_template.json"))
sc.pop("site")
sc["site_id"] = sys.argv[1]
json.dump(sc, open("job.json", "w"))
EOF
rss_site=$(($(awk '/VmRSS/ {print $2}' "/proc/$daemon/status") / 1024))
curl -sS --fail-with-body -o job_resp.json -H 'Content-Type: application/json' \
  --data-binary @job.json "$url/v1/jobs" || {
  cat job_resp.json
  exit 1
}
job_id="$(python3 -c 'import json; print(json.load(open("job_resp.json"))["job_id"])')"
start=$(date +%s.%N)
until curl -sS -f "$url/v1/jobs/$job_id" | grep -q '"state":"done"'; do
  curl -sS -f "$url/v1/jobs/$job_id" | grep -q '"state":"\(failed\|cancelled\)"' && {
    curl -sS "$url/v1/jobs/$job_id"
    exit 1
  }
  sleep 0.2
done
job_s=$(python3 -c "import time; print(f'{time.time() - $start:.1f}')")
step "GET /v1/jobs/{id}/maps (first request: the export)" \
  curl -sS --fail-with-body -o maps.json "$url/v1/jobs/$job_id/maps"
peak_daemon=$(($(awk '/VmHWM/ {print $2}' "/proc/$daemon/status") / 1024))
rss_daemon=$(($(awk '/VmRSS/ {print $2}' "/proc/$daemon/status") / 1024))

echo "### $((2 * (n - 1) * (n - 1))) terrain triangles ($n × $n DEM at 1 m)"
echo
echo "| step | wall | peak RSS |"
echo "|---|---|---|"
printf '%s\n' "${rows[@]}"
echo
echo "- run: $run_line"
echo "- fragsimd: ${rss_site} MB resident holding the site; job of $samples histories done in" \
  "${job_s} s from submission (polled every 0.2 s); daemon peak ${peak_daemon} MB," \
  "${rss_daemon} MB resident at the end"
