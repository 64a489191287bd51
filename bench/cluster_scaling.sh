#!/usr/bin/env bash
# Strong scaling of a divided run, and the cost of its pieces, for docs/cluster.md ("Scaling").
#
#   bench/cluster_scaling.sh [SCALE] [RANKS] [BUILD_DIR]
#
# The demo scenario with --samples-scale SCALE (default 2: 160,000 histories), one thread per
# rank. Prints Markdown tables:
#  1. `fragsim run --threads 1` against `mpirun -np P fragsim-mpi run --threads 1` for P in RANKS
#     (default "1 2 4"): wall time (mpirun's start and the merge included), speed-up, and
#     efficiency per core used (min(P, cores)); P above the core count is oversubscribed.
#  2. The shard/merge path: each of P shards timed alone (`fragsim run --shard i/P`), the size of
#     its partial.fsp, and `fragsim merge` of all P.
# Every divided run's summary.json is checked equal to the one-process run (timing and
# provenance aside): the script fails otherwise. Scratch in ${TMPDIR:-/tmp}/fragsim-scaling.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scale="${1:-2}"
ranks="${2:-1 2 4}"
build="$(cd "${3:-$root/build}" && pwd)"
fragsim="$build/cli/fragsim"
mpi="$build/mpi/fragsim-mpi"
scenario="$root/examples/demo/scenario.json"
work="${TMPDIR:-/tmp}/fragsim-scaling"
cores=$(nproc)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
rm -rf "$work"
mkdir -p "$work"
trap 'rm -rf "$work"' EXIT

wall() {  # wall seconds of a command (GNU time), its output to $work/log
  /usr/bin/time -f "%e" -o "$work/t" "$@" >"$work/log" 2>&1 || {
    cat "$work/log" >&2
    exit 1
  }
  cat "$work/t"
}
same() {  # the figures of two summary.json files are equal
  python3 - "$1" "$2" <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for j in (a, b):
    j.pop("timing"); j.pop("provenance")
sys.exit(0 if a == b else 1)
EOF
}

t1=$(wall "$fragsim" run "$scenario" --out "$work/one" --samples-scale "$scale" --threads 1 --quiet)
histories=$(python3 -c "import json;print(json.load(open('$work/one/summary.json'))['histories_done'])")
echo "demo x $scale: $histories histories, $cores cores; one process, 1 thread: $t1 s"
echo
echo "| ranks | wall | speed-up | efficiency per core used | figures |"
echo "|---|---|---|---|---|"
for p in $ranks; do
  t=$(wall mpirun -np "$p" "$mpi" run "$scenario" --out "$work/np$p" --samples-scale "$scale" \
    --threads 1 --quiet)
  same "$work/one/summary.json" "$work/np$p/summary.json" || {
    echo "cluster_scaling: $p ranks changed the figures" >&2
    exit 1
  }
  used=$((p < cores ? p : cores))
  python3 -c "
t1, t, p, used = $t1, $t, $p, $used
note = ' (oversubscribed)' if p > used else ''
print(f'| {p}{note} | {t:.2f} s | {t1 / t:.2f} | {t1 / t / used:.0%} | bit-identical |')"
done
echo
for p in $ranks; do
  [ "$p" -gt 1 ] || continue
  echo "Shards of $p, one at a time:"
  echo
  echo "| shard | wall | partial.fsp |"
  echo "|---|---|---|"
  parts=()
  for ((i = 0; i < p; i++)); do
    t=$(wall "$fragsim" run "$scenario" --out "$work/s$p-$i" --samples-scale "$scale" \
      --threads 1 --quiet --shard "$i/$p")
    size=$(stat -c %s "$work/s$p-$i/partial.fsp")
    echo "| $i/$p | $t s | $(python3 -c "print(f'{$size / 2**20:.1f} MiB')") |"
    parts+=("$work/s$p-$i/partial.fsp")
  done
  t=$(wall "$fragsim" merge "$scenario" "${parts[@]}" --out "$work/m$p" --samples-scale "$scale" \
    --quiet)
  same "$work/one/summary.json" "$work/m$p/summary.json" || {
    echo "cluster_scaling: the merge of $p shards changed the figures" >&2
    exit 1
  }
  echo "| merge of $p (site build and outputs included) | $t s | bit-identical |"
  echo
done
