#!/usr/bin/env bash
# The Slurm job array of deploy/cluster/ against a one-process run (docs/cluster-slurm-k8s.md).
#
# The demo scenario at --samples-scale 0.02 in N=3 shards:
#   1. reference: `fragsim run` in one process;
#   2. direct path (always): each array task's command line (fragsim-shards.sbatch with
#      SLURM_ARRAY_TASK_ID / SLURM_CPUS_PER_TASK set, in shuffled order), then fragsim-merge.sbatch;
#   3. Slurm path: a private single-node Slurm (deploy/cluster/slurm-local.sh, in a temp dir,
#      stopped at the end) and submit-slurm.sh --wait; skipped, with the reason printed, when no
#      Slurm can start here (not root, slurm-wlm/munge missing, daemons failing);
#   and each merged result.h5/summary.json must equal the reference bit for bit (timing aside,
#   tests/cluster/compare_runs.py). Refusals checked too: a shard missing, a shard twice, a shard
#   of another seed, bad arguments, a failing shard under Slurm (the merge must not run).
#
# Environment: FRAGSIM (the fragsim binary; default build/cli/fragsim), FRAGSIM_TEST_SLURM =
#   auto (default: private cluster if it starts, else direct path only) | private (must start) |
#   existing (use the cluster SLURM_CONF / the client commands reach; FRAGSIM_TEST_SBATCH_ARGS
#   are added to sbatch, e.g. "--partition=debug --time=5") | direct (no Slurm);
#   KEEP_TMP=1 keeps the temp dir.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cluster="$root/deploy/cluster"
fragsim="${FRAGSIM:-$root/build/cli/fragsim}"
mode="${FRAGSIM_TEST_SLURM:-auto}"
scenario="$root/examples/demo/scenario.json"
scale=0.02
n=3
py="$(command -v /usr/bin/python3 || command -v python3 || true)"

fail() {
  echo "FAIL: $*" >&2
  exit 1
}
step() { echo "== $*"; }

case "$mode" in auto | private | existing | direct) ;; *) fail "FRAGSIM_TEST_SLURM='$mode'" ;; esac
[ -x "$fragsim" ] || fail "fragsim binary '$fragsim' not found (set FRAGSIM)"
[ -n "$py" ] || fail "python3 not found (compare_runs.py)"
fragsim="$(cd "$(dirname "$fragsim")" && pwd)/$(basename "$fragsim")"
run_help="$("$fragsim" run --help 2>&1 || true)"  # not piped into grep -q: SIGPIPE + pipefail
if ! "$fragsim" merge --help > /dev/null 2>&1 || ! grep -q -- '--shard' <<< "$run_help"; then
  fail "$fragsim has no sharded runs ('fragsim run --shard I/N', 'fragsim merge'): contract not built"
fi

tmp="$(mktemp -d "${TMPDIR:-/tmp}/fragsim-cluster-test.XXXXXX")"
chmod 0711 "$tmp"  # munged (private Slurm) wants its socket's directories searchable by all
slurm_dir="$tmp/slurm"
started_slurm=0
cleanup() {
  local rc=$?
  if [ "$started_slurm" -eq 1 ]; then
    "$cluster/slurm-local.sh" stop "$slurm_dir" || echo "warning: slurm-local.sh stop failed" >&2
  fi
  if [ "${KEEP_TMP:-0}" = 1 ] || [ "$rc" -ne 0 ]; then
    echo "(files kept in $tmp)"
  else
    rm -rf -- "$tmp"
  fi
}
trap cleanup EXIT
trap 'exit 143' TERM INT  # ctest's timeout: still stop the private cluster (cleanup)

# expect CODE WHAT PATTERN CMD...: CMD must exit with CODE and print PATTERN (ERE, any case).
expect() {
  local code="$1" what="$2" pattern="$3" rc=0 out
  shift 3
  out="$("$@" 2>&1)" || rc=$?
  if [ "$rc" -ne "$code" ]; then
    printf '%s\n' "$out" | tail -n 20 >&2
    fail "$what: exit $rc, expected $code"
  fi
  if [ -n "$pattern" ] && ! grep -qiE -- "$pattern" <<< "$out"; then
    printf '%s\n' "$out" | tail -n 20 >&2
    fail "$what: exit $code as expected but no message matching /$pattern/"
  fi
  if [ -n "$pattern" ]; then
    echo "ok: $what (exit $code): $(grep -iE -m1 -- "$pattern" <<< "$out" || true)"
  else
    echo "ok: $what (exit $code): $(tail -n 1 <<< "$out")"
  fi
}

compare() {  # reference candidate what
  "$py" "$root/tests/cluster/compare_runs.py" "$1" "$2" || fail "$3: merged result differs from the one-process run"
}

run_task() {  # what fragsim-shards.sbatch does for array task $1 of N, outside Slurm
  SLURM_ARRAY_TASK_ID="$1" SLURM_ARRAY_TASK_COUNT="$n" SLURM_CPUS_PER_TASK=1 FRAGSIM="$fragsim" \
    bash "$cluster/fragsim-shards.sbatch" "$2" "$3" "$n" --samples-scale "$scale"
}
merge() {  # scenario workdir
  FRAGSIM="$fragsim" bash "$cluster/fragsim-merge.sbatch" "$1" "$2" "$n" --samples-scale "$scale"
}

t0=$(date +%s)
step "reference: one process, $fragsim run (samples-scale $scale)"
"$fragsim" run "$scenario" --out "$tmp/ref" --threads 2 --samples-scale "$scale" --quiet ||
  fail "the reference run exited $?"
[ -s "$tmp/ref/summary.json" ] || fail "reference run wrote no summary.json"

step "the comparison can fail: one double of summary.json moved by one ulp"
mkdir -p "$tmp/nudged"
cp "$tmp/ref/results.h5" "$tmp/nudged/"
"$py" - "$tmp/ref/summary.json" "$tmp/nudged/summary.json" << 'EOF'
import json, math, sys
s = json.load(open(sys.argv[1]))
s["hazardous_fragment_distance_m"] = math.nextafter(s["hazardous_fragment_distance_m"], math.inf)
json.dump(s, open(sys.argv[2], "w"))
EOF
expect 1 "compare_runs.py tells a one-ulp change" "hazardous_fragment_distance_m" \
  "$py" "$root/tests/cluster/compare_runs.py" "$tmp/ref" "$tmp/nudged"

# --- direct path -------------------------------------------------------------------------------
step "direct path: the array tasks' command lines, shuffled, then the merge script"
order="$(shuf -i 0-$((n - 1)) | tr '\n' ' ')"
[ "$order" != "$(seq 0 $((n - 1)) | tr '\n' ' ')" ] || order="$(seq $((n - 1)) -1 0 | tr '\n' ' ')"
echo "task order: $order"
work="$tmp/direct"
for i in $order; do
  run_task "$i" "$scenario" "$work" || fail "array task $i's command line exited $?"
done
merge "$scenario" "$work" || fail "the merge script exited $?"
compare "$tmp/ref" "$work/result" "direct path"
echo "ok: direct path: merged result equals the one-process run"

step "refusals"
expect 2 "fragsim run --shard 3/2" "shard" \
  "$fragsim" run "$scenario" --out "$tmp/bad" --shard 3/2 --samples-scale "$scale" --quiet
expect 2 "array task outside 0..N-1" "outside shards" run_task 3 "$scenario" "$tmp/bad"
expect 2 "array size other than N" "tasks but N" env SLURM_ARRAY_TASK_ID=0 SLURM_ARRAY_TASK_COUNT=4 \
  FRAGSIM="$fragsim" bash "$cluster/fragsim-shards.sbatch" "$scenario" "$tmp/bad" "$n"
expect 2 "no SLURM_ARRAY_TASK_ID" "SLURM_ARRAY_TASK_ID" env -u SLURM_ARRAY_TASK_ID \
  FRAGSIM="$fragsim" bash "$cluster/fragsim-shards.sbatch" "$scenario" "$tmp/bad" "$n"
expect 2 "N not a number" "positive integer" env SLURM_ARRAY_TASK_ID=0 FRAGSIM="$fragsim" \
  bash "$cluster/fragsim-shards.sbatch" "$scenario" "$tmp/bad" x
expect 2 "shards script without arguments" "usage" bash "$cluster/fragsim-shards.sbatch"
expect 2 "merge script, scenario missing" "not found" merge "$tmp/none.json" "$work"

cp -r "$work" "$tmp/missing"
rm -rf "$tmp/missing/result" "$tmp/missing/shard-1"
expect 2 "merge script, shard 1 deleted" "shard\(s\) 1 " merge "$scenario" "$tmp/missing"
[ ! -e "$tmp/missing/result/summary.json" ] || fail "a refused merge wrote summary.json"
expect 2 "fragsim merge, shard 1 missing" "shard" "$fragsim" merge "$scenario" \
  "$work/shard-0/partial.fsp" "$work/shard-2/partial.fsp" --out "$tmp/bad-merge" --samples-scale "$scale"
[ ! -e "$tmp/bad-merge/summary.json" ] || fail "a refused fragsim merge wrote summary.json"

cp -r "$work" "$tmp/twice"
rm -rf "$tmp/twice/result"
cp "$tmp/twice/shard-0/partial.fsp" "$tmp/twice/shard-1/partial.fsp"
expect 2 "merge script, shard 0 twice (in place of 1)" "shard" merge "$scenario" "$tmp/twice"
[ ! -e "$tmp/twice/result/summary.json" ] || fail "a refused merge wrote summary.json"
expect 2 "fragsim merge, shard 2 given twice" "shard" "$fragsim" merge "$scenario" \
  "$work/shard-0/partial.fsp" "$work/shard-1/partial.fsp" "$work/shard-2/partial.fsp" \
  "$work/shard-2/partial.fsp" --out "$tmp/bad-merge" --samples-scale "$scale"

"$py" - "$scenario" "$tmp/other-seed.json" << 'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
s["settings"]["seed"] = s["settings"]["seed"] + 1
json.dump(s, open(sys.argv[2], "w"))
EOF
cp -r "$work" "$tmp/foreign"
rm -rf "$tmp/foreign/result" "$tmp/foreign/shard-1"
run_task 1 "$tmp/other-seed.json" "$tmp/foreign" || fail "shard 1 of other-seed.json exited $?"
expect 2 "merge script, shard 1 of another seed" "seed|scenario" merge "$scenario" "$tmp/foreign"
expect 2 "merge script, partials of another scenario" "seed|scenario" merge "$tmp/other-seed.json" "$work"

cp -r "$work" "$tmp/rescaled"
rm -rf "$tmp/rescaled/result" "$tmp/rescaled/shard-2"
SLURM_ARRAY_TASK_ID=2 SLURM_CPUS_PER_TASK=1 FRAGSIM="$fragsim" bash "$cluster/fragsim-shards.sbatch" \
  "$scenario" "$tmp/rescaled" "$n" --samples-scale 0.03
expect 2 "merge script, shard 2 of another --samples-scale" "samples-scale" merge "$scenario" "$tmp/rescaled"
expect 2 "merge script given another --samples-scale than the shards" "samples-scale" \
  env FRAGSIM="$fragsim" bash "$cluster/fragsim-merge.sbatch" "$scenario" "$work" "$n" --samples-scale 0.03

expect 2 "submit-slurm.sh N=0" "positive integer" \
  "$cluster/submit-slurm.sh" --fragsim "$fragsim" "$scenario" "$tmp/bad" 0
expect 2 "submit-slurm.sh, scenario missing" "not found" \
  "$cluster/submit-slurm.sh" --fragsim "$fragsim" "$tmp/none.json" "$tmp/bad" 3
expect 2 "submit-slurm.sh, unknown option" "unknown option" \
  "$cluster/submit-slurm.sh" --fragsim "$fragsim" --bogus "$scenario" "$tmp/bad" 3
expect 2 "submit-slurm.sh, two positional arguments" "expected SCENARIO WORKDIR N" \
  "$cluster/submit-slurm.sh" --fragsim "$fragsim" "$scenario" "$tmp/bad"

# --- Slurm path --------------------------------------------------------------------------------
slurm_path=""
case "$mode" in
  direct) why="FRAGSIM_TEST_SLURM=direct" ;;
  existing)
    timeout 20 sinfo > /dev/null 2>&1 || fail "FRAGSIM_TEST_SLURM=existing but sinfo fails"
    slurm_path="the existing cluster (SLURM_CONF=${SLURM_CONF:-default})"
    ;;
  auto | private)
    rc=0
    out="$("$cluster/slurm-local.sh" start "$slurm_dir" 2>&1)" || rc=$?
    if [ "$rc" -eq 0 ]; then
      started_slurm=1
      eval "$(grep '^export SLURM_CONF=' <<< "$out")"
      slurm_path="a private single-node cluster ($slurm_dir, started by slurm-local.sh)"
    else
      [ -d "$slurm_dir" ] && started_slurm=1
      why="slurm-local.sh start exited $rc: $(tail -n 5 <<< "$out" | tr '\n' ' ')"
      [ "$mode" = auto ] || fail "FRAGSIM_TEST_SLURM=private: $why"
    fi
    ;;
esac

if [ -n "$slurm_path" ]; then
  step "Slurm path: $slurm_path"
  timeout 30 sinfo
  read -r -a extra <<< "${FRAGSIM_TEST_SBATCH_ARGS:-}"
  rc=0
  ids="$("$cluster/submit-slurm.sh" --wait --timeout 90 --samples-scale "$scale" \
    --fragsim "$fragsim" "$scenario" "$tmp/slurm-run" "$n" -- "${extra[@]}")" || rc=$?
  [ "$rc" -eq 0 ] || {
    cat "$tmp"/slurm-run/logs/* >&2 || true
    fail "submit-slurm.sh --wait exited $rc (jobs: ${ids:-none})"
  }
  echo "jobs (array, merge): $ids"
  compare "$tmp/ref" "$tmp/slurm-run/result" "Slurm path"
  echo "ok: Slurm path: merged result equals the one-process run"

  step "Slurm path: a failing shard (invalid scenario) must fail the submission and skip the merge"
  echo '{"schema": "fragsim.scenario/1"}' > "$tmp/invalid.json"
  expect 2 "submit-slurm.sh --wait, shards exit 2" "merge job .*cancel|shard .*FAILED" \
    "$cluster/submit-slurm.sh" --wait --timeout 90 --samples-scale "$scale" \
    --fragsim "$fragsim" "$tmp/invalid.json" "$tmp/slurm-bad" "$n" -- "${extra[@]}"
  [ ! -e "$tmp/slurm-bad/result/summary.json" ] || fail "the merge ran after failed shards"
  paths="direct and Slurm ($slurm_path)"
else
  echo "== Slurm path skipped: $why"
  paths="direct only (Slurm path skipped: $why)"
fi

echo "PASS: $paths; $(($(date +%s) - t0)) s"
