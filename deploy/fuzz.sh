#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang, ASan + UBSan, into ./build-fuzz) and runs each one
# for SECONDS (default 60). Fails on any crash, sanitizer report, leak, input slower than 1 s
# (-timeout=1) or RSS above 2 GiB. docs/testing.md.
#
#   deploy/fuzz.sh                 # 60 s per target (CI sets FUZZ_SECONDS=30)
#   deploy/fuzz.sh 3600            # the long run: an hour per target
#   FUZZ_RUNS=10000000 deploy/fuzz.sh 86400   # stop each target at 10 M executions instead
#   deploy/fuzz.sh 60 fuzz_site    # some targets only
#
# The seed corpora in fuzz/corpus/ are copied to a scratch directory first: the tree is never
# modified. FUZZ_KEEP=1 keeps the scratch directory (the grown corpora) and says where it is;
# FUZZ_CORPUS=DIR fuzzes the corpora DIR/<target>/corpus (e.g. a kept scratch directory, to go
# on from an earlier run; the seeds are added to them) instead of fresh copies.
# FUZZ_JOBS (default: the number of cores) targets run at a time, each one process.
# FUZZ_TIMEOUT (default 1 s) is wall-clock time: on a machine busy with other work, a run in the
# background needs a larger one (the slowest input is printed; replay it to time it alone).
# A failing input is saved in build-fuzz/artifacts/<target>/; replay it with
#   build-fuzz/fuzz/<target> build-fuzz/artifacts/<target>/crash-...
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_scenario fuzz_site fuzz_job fuzz_service fuzz_partial)
# FUZZ_BUILD=DIR uses a tree configured with FRAGSIM_FUZZ=ON already (deploy/sanitize.sh's ASan
# tree, which builds the fuzz targets beside the tests: one build fewer in CI).
build="${FUZZ_BUILD:-$root/build-fuzz}"

"$root/deploy/install-deps.sh"
if [ -z "${FUZZ_BUILD:-}" ]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DFRAGSIM_FUZZ=ON -DFRAGSIM_BUILD_TESTS=OFF -DFRAGSIM_BUILD_BENCH=OFF \
    -DFRAGSIM_WERROR=ON >/dev/null
elif ! grep -q '^FRAGSIM_FUZZ:BOOL=ON$' "$build/CMakeCache.txt" 2>/dev/null; then
  echo "fuzz: FUZZ_BUILD=$build is not a tree configured with -DFRAGSIM_FUZZ=ON" >&2
  exit 2
fi
build_t0=$(date +%s)
nice -n 5 cmake --build "$build" -j "$(nproc 2>/dev/null || echo 2)" --target "${targets[@]}"
echo "fuzz: build $(($(date +%s) - build_t0)) s"
[ -z "${FRAGSIM_CI_TIMES:-}" ] ||
  echo "  fuzz: build $(($(date +%s) - build_t0)) s" >>"$FRAGSIM_CI_TIMES"

scratch="$(mktemp -d "${TMPDIR:-/tmp}/fragsim-fuzz.XXXXXX")"
if [ "${FUZZ_KEEP:-0}" = 1 ]; then
  echo "fuzz: corpora and logs kept in $scratch"
else
  trap 'rm -rf "$scratch"' EXIT
fi

# Reports are fatal and come with a stack; leaks are checked (libFuzzer's -detect_leaks).
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=1:strict_string_checks=1"
export UBSAN_OPTIONS="halt_on_error=1:abort_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$root/deploy/sanitizers/lsan.supp:print_suppressions=0"
runs_flag=()
[ -z "${FUZZ_RUNS:-}" ] || runs_flag=(-runs="$FUZZ_RUNS")

# One target: its summary goes to $scratch/$t/summary, ok or FAILED to $scratch/$t/status.
fuzz_one() {
  local t="$1" corpus log start status execs rate cov slowest
  corpus="$scratch/$t/corpus"
  [ -z "${FUZZ_CORPUS:-}" ] || corpus="$FUZZ_CORPUS/$t/corpus"
  mkdir -p "$corpus" "$scratch/$t/tmp" "$build/artifacts/$t"
  cp "$root/fuzz/corpus/$t/"* "$corpus/"
  log="$scratch/$t/log"
  start=$(date +%s)
  # TMPDIR: fuzz_service's data directory lives in the scratch directory too.
  if TMPDIR="$scratch/$t/tmp" nice -n 5 "$build/fuzz/$t" -max_total_time="$seconds" \
      "${runs_flag[@]}" -timeout="${FUZZ_TIMEOUT:-1}" -rss_limit_mb=2048 -malloc_limit_mb=2048 \
      -max_len=16384 \
      -dict="$root/fuzz/fragsim.dict" -artifact_prefix="$build/artifacts/$t/" \
      -print_final_stats=1 "$corpus" >"$log" 2>&1; then
    status=ok
  else
    status=FAILED
  fi
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)"
  # `|| true`: a target that fails on a seed input prints no coverage (the summary must follow).
  cov="$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2 || true)"
  slowest="$(sed -n 's/^stat::slowest_unit_time_sec: *//p' "$log" | tail -n 1)"
  {
    echo "fuzz: $t $status: ${execs:-?} executions in $(($(date +%s) - start)) s" \
      "(${rate:-?}/s), coverage ${cov:-?}, corpus $(ls "$corpus" | wc -l) inputs," \
      "slowest input ${slowest:-?} s"
    if [ "$status" != ok ]; then
      grep -B2 -A40 -m1 -E 'ERROR: |runtime error|==ERROR|fuzz invariant|deadly signal|timeout' \
        "$log" || tail -n 60 "$log"
    fi
  } >"$scratch/$t/summary"
  echo "$status" >"$scratch/$t/status"
}

# FUZZ_JOBS targets at a time (default: one per core; each fuzzer is one process on one core),
# so that CI's 5 x 60 s take 3 minutes on 2 cores, not 5. Summaries are printed in target order.
jobs="${FUZZ_JOBS:-$(nproc 2>/dev/null || echo 2)}"
running=0
for t in "${targets[@]}"; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
  fuzz_one "$t" &
  running=$((running + 1))
done
wait || true
failed=()
for t in "${targets[@]}"; do
  cat "$scratch/$t/summary" 2>/dev/null || echo "fuzz: $t FAILED: no summary"
  [ "$(cat "$scratch/$t/status" 2>/dev/null)" = ok ] || failed+=("$t")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: FAILED: ${failed[*]} (inputs in $build/artifacts/)" >&2
  exit 1
fi
echo "fuzz: all ${#targets[@]} targets passed"
