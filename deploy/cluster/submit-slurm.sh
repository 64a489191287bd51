#!/usr/bin/env bash
# Submits a sharded fragsim run to Slurm: a job array of N shards (fragsim-shards.sbatch), then
# the merge (fragsim-merge.sbatch) with --dependency=afterok:<array> --kill-on-invalid-dep=yes.
#
#   deploy/cluster/submit-slurm.sh [OPTIONS] SCENARIO WORKDIR N [-- SBATCH_ARGS...]
#
# Prints "ARRAY_JOB_ID MERGE_JOB_ID" on stdout as soon as both are submitted (messages go to
# stderr). WORKDIR (created; must be on a file system every node sees) receives:
#   scenario.json           the scenario, copied at submission (shards and merge read this copy)
#   shard-I/partial.fsp     shard I's tally state        logs/shards-<array>_<I>.out  its log
#   result/                 summary.json, results.h5, ... logs/merge-<job>.out         its log
#
# Options:
#   --wait               wait for the merge; exit 0 only if it COMPLETED. Otherwise the exit status
#                        of what failed: the merge's, else the highest failed shard's (1 when a job
#                        ended without one: cancelled, timed out, node failure); 124 on --timeout
#   --timeout S          with --wait: give up waiting after S seconds (jobs are left as they are)
#   --samples-scale X    passed to fragsim run and to fragsim merge
#   --cpus-per-task C    CPUs (threads) per shard (default 1)
#   --max-parallel K     at most K shards running at once (--array=0-(N-1)%K)
#   --fragsim PATH       the fragsim binary as the nodes see it (default: $FRAGSIM, else
#                        `fragsim` on this PATH)
#   --overwrite          reuse a WORKDIR that holds a previous run (its shard-*/ and result/ are
#                        removed first); without it such a WORKDIR is refused
#   -- SBATCH_ARGS       given to both sbatch calls (e.g. --partition=P --account=A --time=1:00:00)
#
# Exit status without --wait: 0 submitted; 2 bad arguments; sbatch's status if it fails (when the
# merge cannot be submitted, the array is cancelled).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
die() {
  echo "submit-slurm: $*" >&2
  exit 2
}
usage() {  # the header comment; exit status $1
  awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}" >&2
  exit "$1"
}

wait_for=0
timeout_s=0
samples_scale=""
cpus=1
max_parallel=""
fragsim="${FRAGSIM:-}"
overwrite=0
pos=()
sbatch_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --wait) wait_for=1 ;;
    --timeout | --samples-scale | --cpus-per-task | --max-parallel | --fragsim)
      [ $# -ge 2 ] || die "$1 needs a value"
      case "$1" in
        --timeout) timeout_s="$2" ;;
        --samples-scale) samples_scale="$2" ;;
        --cpus-per-task) cpus="$2" ;;
        --max-parallel) max_parallel="$2" ;;
        --fragsim) fragsim="$2" ;;
      esac
      shift
      ;;
    --overwrite) overwrite=1 ;;
    -h | --help) usage 0 ;;
    --)
      shift
      sbatch_args=("$@")
      break
      ;;
    -*) die "unknown option '$1' (sbatch options go after --)" ;;
    *) pos+=("$1") ;;
  esac
  shift
done
[ ${#pos[@]} -eq 3 ] || die "expected SCENARIO WORKDIR N, got ${#pos[@]} argument(s) (--help)"
scenario="${pos[0]}"
workdir="${pos[1]}"
n="${pos[2]}"

[[ "$n" =~ ^[1-9][0-9]*$ ]] || die "N must be a positive integer, got '$n'"
[[ "$cpus" =~ ^[1-9][0-9]*$ ]] || die "--cpus-per-task must be a positive integer, got '$cpus'"
[ -z "$max_parallel" ] || [[ "$max_parallel" =~ ^[1-9][0-9]*$ ]] ||
  die "--max-parallel must be a positive integer, got '$max_parallel'"
[[ "$timeout_s" =~ ^[0-9]+$ ]] || die "--timeout must be a whole number of seconds, got '$timeout_s'"
[ -z "$samples_scale" ] || [[ "$samples_scale" =~ ^[0-9]*\.?[0-9]+([eE][-+]?[0-9]+)?$ ]] ||
  die "--samples-scale must be a positive number, got '$samples_scale'"
[ -f "$scenario" ] || die "scenario '$scenario' not found"
if [ -z "$fragsim" ]; then
  fragsim="$(command -v fragsim)" || die "no fragsim on PATH: give --fragsim PATH or set FRAGSIM"
fi
case "$fragsim" in
  */*) fragsim="$(cd "$(dirname "$fragsim")" && pwd)/$(basename "$fragsim")" ;;
  *) fragsim="$(command -v "$fragsim")" || die "fragsim binary '$fragsim' not found" ;;
esac
[ -x "$fragsim" ] || die "fragsim binary '$fragsim' is not executable"
case "$fragsim" in *,*) die "the fragsim path must not contain a comma (sbatch --export)" ;; esac
command -v sbatch > /dev/null || die "sbatch not found: no Slurm client here"
for s in fragsim-shards.sbatch fragsim-merge.sbatch; do
  [ -f "$here/$s" ] || die "$here/$s is missing"
done

mkdir -p -- "$workdir" || die "cannot create WORKDIR '$workdir'"
workdir="$(cd "$workdir" && pwd)"
shopt -s nullglob
old=("$workdir"/shard-*)
shopt -u nullglob
[ ! -e "$workdir/result" ] || old+=("$workdir/result")
if [ ${#old[@]} -gt 0 ]; then
  [ "$overwrite" -eq 1 ] || die "$workdir holds a previous run (${old[*]##*/}): use a new WORKDIR or --overwrite"
  rm -rf -- "${old[@]}"
fi
mkdir -p "$workdir/logs"
cp -- "$scenario" "$workdir/scenario.json.tmp.$$"
mv -f -- "$workdir/scenario.json.tmp.$$" "$workdir/scenario.json"

scale_args=()
[ -z "$samples_scale" ] || scale_args=(--samples-scale "$samples_scale")
array="0-$((n - 1))${max_parallel:+%$max_parallel}"
common=(--parsable --chdir="$workdir" --export="ALL,FRAGSIM=$fragsim")

array_out="$(sbatch "${common[@]}" --job-name=fragsim-shards --array="$array" \
  --cpus-per-task="$cpus" --output="$workdir/logs/shards-%A_%a.out" "${sbatch_args[@]}" \
  "$here/fragsim-shards.sbatch" "$workdir/scenario.json" "$workdir" "$n" "${scale_args[@]}")" || {
  rc=$?
  echo "submit-slurm: sbatch of the shard array failed ($rc)" >&2
  exit "$rc"
}
array_id="${array_out%%;*}"
[[ "$array_id" =~ ^[0-9]+$ ]] || die "unexpected sbatch output '$array_out'"

merge_out="$(sbatch "${common[@]}" --job-name=fragsim-merge --dependency="afterok:$array_id" \
  --kill-on-invalid-dep=yes --output="$workdir/logs/merge-%j.out" "${sbatch_args[@]}" \
  "$here/fragsim-merge.sbatch" "$workdir/scenario.json" "$workdir" "$n" "${scale_args[@]}")" || {
  rc=$?
  echo "submit-slurm: sbatch of the merge failed ($rc); cancelling array job $array_id" >&2
  scancel "$array_id" || true
  exit "$rc"
}
merge_id="${merge_out%%;*}"
echo "$array_id $merge_id"
echo "submit-slurm: array job $array_id ($n shards, $cpus CPU(s) each), merge job $merge_id" \
  "-> $workdir/result" >&2
[ "$wait_for" -eq 1 ] || exit 0

# --- waiting ------------------------------------------------------------------------------------
# Polls scontrol (no accounting database needed). Not `sbatch --wait`: it exits 0 for a merge that
# was cancelled because a shard failed (Slurm 22.05: the job's exit code stays 0:0).
field() {  # one-line job record, key -> value
  sed -n "s/.* $2=\([^ ]*\).*/\1/p" <<< " $1"
}
state_of() {  # job id -> "STATE EXIT REASON", "GONE" (purged) or "UNKNOWN" (no answer: retry)
  local rec
  rec="$(scontrol show job -o "$1" 2>&1 || true)"
  rec="${rec%%$'\n'*}"
  if [[ "$rec" == *"JobState="* ]]; then
    echo "$(field "$rec" JobState) $(field "$rec" ExitCode) $(field "$rec" Reason)"
  elif [[ "$rec" == *"Invalid job id"* ]]; then
    echo GONE
  else
    echo "UNKNOWN - ${rec:-no answer}"
  fi
}
exit_of() {  # "E:S" -> E, or 1 when 0 (ended badly without an exit code of its own)
  local e="${1%%:*}"
  if [[ "$e" =~ ^[0-9]+$ ]] && [ "$e" -ne 0 ]; then
    echo "$e"
  else
    echo 1
  fi
}
report_shards() {  # prints failed shards; echoes the highest failed exit status (0: none failed)
  local worst=0 rec task st ec e
  while IFS= read -r rec; do
    [ -n "$rec" ] || continue
    task="$(field "$rec" ArrayTaskId)"
    st="$(field "$rec" JobState)"
    ec="$(field "$rec" ExitCode)"
    case "$st" in
      COMPLETED | PENDING | RUNNING | CONFIGURING | COMPLETING) ;;
      *)
        e="$(exit_of "$ec")"
        echo "submit-slurm: shard $task: $st, exit $ec, log $workdir/logs/shards-${array_id}_$task.out" >&2
        [ "$e" -le "$worst" ] || worst="$e"
        ;;
    esac
  done < <(scontrol show job -o "$array_id" 2>/dev/null || true)
  echo "$worst"
}

start=$(date +%s)
while :; do
  read -r st ec reason <<< "$(state_of "$merge_id")"
  case "$st" in
    COMPLETED)
      echo "submit-slurm: merge job $merge_id completed: $workdir/result" >&2
      exit 0
      ;;
    PENDING)
      if [ "$reason" = "DependencyNeverSatisfied" ]; then
        # Sites that do not honour --kill-on-invalid-dep leave it pending for ever.
        scancel "$merge_id" || true
        worst="$(report_shards)"
        echo "submit-slurm: a shard failed; merge job $merge_id cancelled" >&2
        exit "$(exit_of "$worst:0")"
      fi
      ;;
    RUNNING | CONFIGURING | COMPLETING | REQUEUED | RESIZING | SUSPENDED | UNKNOWN) ;;
    GONE)
      echo "submit-slurm: merge job $merge_id is no longer known to slurmctld (MinJobAge?)" >&2
      if [ -s "$workdir/result/summary.json" ]; then
        echo "submit-slurm: $workdir/result/summary.json exists: taking it as done" >&2
        exit 0
      fi
      exit 1
      ;;
    *)
      worst="$(report_shards)"
      if [ "$worst" -ne 0 ]; then
        echo "submit-slurm: merge job $merge_id $st ($reason) after failed shards" >&2
        exit "$worst"
      fi
      echo "submit-slurm: merge job $merge_id $st, exit $ec ($reason);" \
        "log: $workdir/logs/merge-$merge_id.out" >&2
      exit "$(exit_of "$ec")"
      ;;
  esac
  if [ "$timeout_s" -gt 0 ] && [ $(($(date +%s) - start)) -ge "$timeout_s" ]; then
    echo "submit-slurm: still waiting after $timeout_s s (merge job $merge_id $st); jobs left" \
      "as they are" >&2
    exit 124
  fi
  sleep "${FRAGSIM_SUBMIT_POLL_S:-1}"
done
