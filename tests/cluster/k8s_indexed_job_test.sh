#!/usr/bin/env bash
# The Kubernetes Indexed Job of deploy/cluster/k8s/ without Kubernetes (none here): the pods'
# command lines, taken from the manifests (tests/cluster/k8s_pod.py: $(VAR) expanded as the
# kubelet does, the volumes' mount paths moved under a temp dir, env from the manifest, in a
# clean environment), run for JOB_COMPLETION_INDEX = 0..N-1 in shuffled order, then the merge
# Job's; the result must equal a one-process `fragsim run` bit for bit (timing aside). The demo
# scenario stands in for the ConfigMap, FRAGSIM_SAMPLES_SCALE is set to 0.02 in both pods (as a
# user would edit it), FRAGSIM_THREADS (the CPU limit) to 1. Also: the manifests agree with
# each other (N, run folder, volumes; k8s_pod.py check), the merge refuses a missing shard, a
# pod without JOB_COMPLETION_INDEX fails.
# Environment: FRAGSIM (default build/cli/fragsim); KEEP_TMP=1 keeps the temp dir.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
k8s="$root/deploy/cluster/k8s"
fragsim="${FRAGSIM:-$root/build/cli/fragsim}"
scenario="$root/examples/demo/scenario.json"
scale=0.02
py="$(command -v /usr/bin/python3 || command -v python3 || true)"

fail() {
  echo "FAIL: $*" >&2
  exit 1
}
[ -x "$fragsim" ] || fail "fragsim binary '$fragsim' not found (set FRAGSIM)"
[ -n "$py" ] || fail "python3 not found"
"$py" -c 'import yaml' 2> /dev/null || fail "$py has no PyYAML (apt-get install python3-yaml)"
fragsim="$(cd "$(dirname "$fragsim")" && pwd)/$(basename "$fragsim")"
"$fragsim" merge --help > /dev/null 2>&1 || fail "$fragsim has no 'merge': contract not built"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/fragsim-k8s-test.XXXXXX")"
cleanup() {
  local rc=$?
  if [ "${KEEP_TMP:-0}" = 1 ] || [ "$rc" -ne 0 ]; then
    echo "(files kept in $tmp)"
  else
    rm -rf -- "$tmp"
  fi
}
trap cleanup EXIT

shards_yaml="$k8s/fragsim-indexed-job.yaml"
merge_yaml="$k8s/fragsim-merge-job.yaml"
echo "== the manifests parse and agree"
n="$("$py" "$root/tests/cluster/k8s_pod.py" check "$shards_yaml" "$merge_yaml" "$k8s/fragsim-work-pvc.yaml")" ||
  fail "k8s_pod.py check"
echo "ok: N = $n (completions = FRAGSIM_SHARDS, same run folder, volumes and image in both Jobs)"

# The pods' stand-ins: the ConfigMap's file, the shared volume, fragsim on the PATH.
mkdir -p "$tmp/pod/scenario" "$tmp/pod/work" "$tmp/bin"
cp "$scenario" "$tmp/pod/scenario/scenario.json"
ln -s "$fragsim" "$tmp/bin/fragsim"

pod() {  # manifest [NAME=VALUE...]: runs its container's command as the kubelet would
  local manifest="$1" e
  shift
  local -a argv env_args=(PATH="$tmp/bin:/usr/local/bin:/usr/bin:/bin" HOME="$tmp")
  mapfile -d '' -t argv < <("$py" "$root/tests/cluster/k8s_pod.py" argv "$manifest" "$tmp/pod")
  [ ${#argv[@]} -gt 0 ] || fail "no command in $manifest"
  while IFS= read -r e; do
    case "$e" in
      *=*) env_args+=("$e") ;;
      FRAGSIM_THREADS) env_args+=(FRAGSIM_THREADS=1) ;;  # resourceFieldRef limits.cpu
      *) fail "$manifest: env $e comes from a valueFrom the test does not provide" ;;
    esac
  done < <("$py" "$root/tests/cluster/k8s_pod.py" env "$manifest")
  env -i "${env_args[@]}" FRAGSIM_SAMPLES_SCALE="$scale" "$@" "${argv[@]}"
}

echo "== reference: one process"
"$fragsim" run "$scenario" --out "$tmp/ref" --threads 2 --samples-scale "$scale" --quiet

order="$(shuf -i 0-$((n - 1)) | tr '\n' ' ')"
echo "== shard pods, JOB_COMPLETION_INDEX in the order $order"
for i in $order; do
  pod "$shards_yaml" JOB_COMPLETION_INDEX="$i" || fail "shard pod $i exited $?"
done
echo "== merge pod"
pod "$merge_yaml" || fail "merge pod exited $?"
run_dir="$(find "$tmp/pod/work" -mindepth 1 -maxdepth 1 -type d | head -n 1)"
[ -s "$run_dir/result/summary.json" ] || fail "no result/summary.json under $tmp/pod/work"
"$py" "$root/tests/cluster/compare_runs.py" "$tmp/ref" "$run_dir/result" ||
  fail "the merged result of the Indexed Job's commands differs from the one-process run"
echo "ok: the Indexed Job's and the merge Job's command lines give the one-process result"

echo "== refusals"
rc=0
pod "$shards_yaml" > "$tmp/out.txt" 2>&1 || rc=$?
[ "$rc" -ne 0 ] || fail "a shard pod without JOB_COMPLETION_INDEX succeeded"
echo "ok: shard pod without JOB_COMPLETION_INDEX: exit $rc: $(head -n 1 "$tmp/out.txt")"
rm -rf "$run_dir/result" "$run_dir/shard-1"
rc=0
pod "$merge_yaml" > "$tmp/out.txt" 2>&1 || rc=$?
[ "$rc" -eq 2 ] || { cat "$tmp/out.txt" >&2; fail "merge pod with shard 1 missing: exit $rc, expected 2"; }
grep -q "no partial for shard 1 " "$tmp/out.txt" || fail "merge pod: no message naming shard 1"
[ ! -e "$run_dir/result/summary.json" ] || fail "a refused merge wrote summary.json"
echo "ok: merge pod with shard 1 missing: exit 2: $(head -n 1 "$tmp/out.txt")"
echo "PASS"
