#!/usr/bin/env bash
# A private single-node Slurm cluster (munged, slurmctld, slurmd) in one directory, for tests and
# trials of the job-array scripts on a machine (or container) without a Slurm installation of its
# own. Everything it starts, writes and listens on is in DIR and on two free loopback ports of its
# own choosing; the machine's /etc/slurm, /etc/munge and system services are not touched.
#
#   deploy/cluster/slurm-local.sh start [DIR]   # idempotent: a running cluster in DIR is kept
#   deploy/cluster/slurm-local.sh status [DIR]  # exit 0 when it answers and its node is usable
#   deploy/cluster/slurm-local.sh env [DIR]     # prints: export SLURM_CONF=DIR/etc/slurm.conf
#   deploy/cluster/slurm-local.sh stop [DIR]    # idempotent: cancels its jobs, stops, removes DIR
#
#   eval "$(deploy/cluster/slurm-local.sh start)"; sinfo; srun hostname; sbatch --array=0-2 ...
#
# DIR defaults to $FRAGSIM_SLURM_DIR, else ${TMPDIR:-/tmp}/fragsim-slurm-<uid>. `start` prints the
# export line on stdout (messages go to stderr), so eval works. Needs root (slurmd launches jobs
# as their user and the config runs everything as root) and Debian 12's packages slurm-wlm and
# munge (deploy/install-deps.sh installs them). Choices that let it run in a container: no cgroups
# (ProctrackType=proctrack/linuxproc, TaskPlugin=task/none, JobAcctGatherType=jobacct_gather/none),
# no accounting database, munged on a socket in DIR with a key of its own (docs/cluster-slurm-k8s.md).
#
# Exit status: 0 done; 1 the cluster did not come up (its logs are printed); 2 bad arguments;
# 3 cannot run here (not root, packages missing).
set -euo pipefail

usage() {
  echo "usage: $0 start|stop|status|env [DIR]" >&2
  exit 2
}

if [ $# -lt 1 ] || [ $# -gt 2 ]; then usage; fi
cmd="$1"
case "$cmd" in start | stop | status | env) ;; *) usage ;; esac
dir="${2:-${FRAGSIM_SLURM_DIR:-${TMPDIR:-/tmp}/fragsim-slurm-$(id -u)}}"
case "$dir" in
  /*) ;;
  *) dir="$PWD/$dir" ;;
esac
dir="${dir%/}"
if [ -z "$dir" ] || [ "$dir" = "/" ]; then
  echo "slurm-local: refusing DIR '/'" >&2
  exit 2
fi
marker="$dir/.fragsim-slurm-local"
conf="$dir/etc/slurm.conf"
partition=fragsim
START_TIMEOUT_S="${FRAGSIM_SLURM_START_TIMEOUT_S:-60}"

log() { echo "slurm-local: $*" >&2; }

# The pid in FILE if that process is alive and was started by us for this DIR (its command line
# or environment names DIR), so that a recycled pid is never signalled.
our_pid() {
  local f="$1" pid
  [ -f "$f" ] || return 1
  pid="$(tr -dc '0-9' < "$f")"
  if [ -z "$pid" ] || [ ! -d "/proc/$pid" ]; then
    return 1
  fi
  local cmdline environ
  cmdline="$(tr '\0' ' ' < "/proc/$pid/cmdline" 2>/dev/null || true)"
  environ="$(tr '\0' '\n' < "/proc/$pid/environ" 2>/dev/null || true)"
  if [[ "$cmdline" == *"$dir/"* ]] || grep -qxF -- "SLURM_CONF=$conf" <<< "$environ"; then
    echo "$pid"
    return 0
  fi
  return 1
}

# Job step daemons (slurmstepd) and their jobs inherit slurmd's environment: SLURM_CONF=$conf.
our_stepds() {
  local p environ
  for p in /proc/[0-9]*; do
    [ "$(head -c 10 "$p/cmdline" 2>/dev/null | tr '\0' ' ')" = "slurmstepd" ] || continue
    environ="$(tr '\0' '\n' < "$p/environ" 2>/dev/null || true)"
    grep -qxF -- "SLURM_CONF=$conf" <<< "$environ" || continue
    echo "${p#/proc/}"
  done
}

stop_pid() {  # pid, name: TERM, up to 10 s, then KILL
  local pid="$1" name="$2"
  kill -TERM "$pid" 2>/dev/null || return 0
  for _ in $(seq 1 100); do
    [ -d "/proc/$pid" ] || return 0
    [ "$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null)" != "Z" ] || return 0
    sleep 0.1
  done
  log "$name (pid $pid) did not stop on SIGTERM in 10 s: SIGKILL"
  kill -KILL "$pid" 2>/dev/null || true
}

need_tools() {
  local missing=() t
  for t in munged munge slurmctld slurmd sinfo scontrol squeue sbatch scancel; do
    command -v "$t" > /dev/null || missing+=("$t")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    log "cannot run here: ${missing[*]} not found (apt-get install slurm-wlm munge)"
    exit 3
  fi
  if [ "$(id -u)" -ne 0 ]; then
    log "cannot run here: needs root (SlurmUser=root; slurmd starts jobs as their owner)"
    exit 3
  fi
}

is_up() {  # the controller answers and our node is usable
  [ -f "$conf" ] || return 1
  our_pid "$dir/run/munged.pid" > /dev/null || return 1
  our_pid "$dir/run/slurmctld.pid" > /dev/null || return 1
  our_pid "$dir/run/slurmd.pid" > /dev/null || return 1
  local state
  state="$(SLURM_CONF="$conf" timeout 10 sinfo -h -N -o '%T' 2>/dev/null)" || return 1
  state="${state%%$'\n'*}"
  case "$state" in
    idle | idle\* | mixed | allocated | completing) return 0 ;;
    *) return 1 ;;
  esac
}

# A loopback TCP port nobody uses, other than $1. Taken below the kernel's ephemeral range
# (net.ipv4.ip_local_port_range): a port there may be the local end of a client connection or of
# a TIME_WAIT socket -- many of them while the daemon tests run -- and slurmctld's bind() would
# then fail with "Address already in use" although nothing listens on it. ss (iproute2) sees
# sockets in every state; without it, a connection attempt sees the listening ones.
free_port() {
  local p lo=10000 hi=32768 e_lo e_hi
  if read -r e_lo e_hi < /proc/sys/net/ipv4/ip_local_port_range 2>/dev/null; then
    if [ "$e_lo" -gt 11024 ]; then hi="$e_lo"; else lo=$((e_hi + 1)) hi=65536; fi
  fi
  [ $((hi - lo)) -ge 1000 ] || { lo=10000; hi=32768; }  # no room outside it: ss must do
  for _ in $(seq 1 200); do
    p=$((lo + RANDOM % (hi - lo)))
    [ "$p" != "${1:-}" ] || continue
    if command -v ss > /dev/null 2>&1; then
      [ -z "$(ss -Htan "( sport = :$p )" 2>/dev/null)" ] || continue
    elif (exec 3<> "/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
      continue
    fi
    echo "$p"
    return 0
  done
  log "no free port found"
  return 1
}

do_stop() {
  local pid name
  if [ -e "$dir" ] && [ ! -f "$marker" ]; then
    log "$dir exists but was not made by this script: left alone"
    exit 2
  fi
  [ -d "$dir" ] || return 0
  if our_pid "$dir/run/slurmctld.pid" > /dev/null; then
    # Cancel this cluster's jobs so that their step daemons end before slurmd does.
    SLURM_CONF="$conf" timeout 10 scancel --partition="$partition" 2>/dev/null || true
    for _ in $(seq 1 50); do
      [ -z "$(our_stepds)" ] && break
      sleep 0.2
    done
  fi
  for name in slurmd slurmctld munged; do
    if pid="$(our_pid "$dir/run/$name.pid")"; then
      stop_pid "$pid" "$name"
    fi
  done
  for pid in $(our_stepds); do
    stop_pid "$pid" slurmstepd
  done
  rm -rf -- "$dir"
  log "stopped, $dir removed"
}

node_hw() {  # the node's CPU layout as slurmd itself sees it (memory is not a consumable here)
  local hw
  hw="$(slurmd -C 2>/dev/null || true)"
  hw="$(grep -oE '(CPUs|Boards|SocketsPerBoard|CoresPerSocket|ThreadsPerCore)=[0-9]+' <<< "${hw%%$'\n'*}" |
    tr '\n' ' ')"
  case "$hw" in
    *CPUs=*) echo "${hw% }" ;;
    *) echo "CPUs=$(nproc)" ;;
  esac
}

write_conf() {
  local host="$1" ctld_port="$2" d_port="$3"
  cat > "$conf" << EOF
# Private single-node cluster of deploy/cluster/slurm-local.sh (generated; removed by 'stop').
ClusterName=fragsimlocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/run/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
PlugStackConfig=$dir/etc/plugstack.conf
MailProg=/bin/true
# No cgroups: a container has no delegated cgroup tree to give slurmd.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# Batch jobs scheduled at once, not up to 3 s later (the default batch_sched_delay).
SchedulerParameters=batch_sched_delay=0
ReturnToService=2
SlurmctldDebug=info
SlurmdDebug=info
NodeName=$host NodeAddr=127.0.0.1 $(node_hw) State=UNKNOWN
PartitionName=$partition Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  : > "$dir/etc/plugstack.conf"
}

show_logs() {
  local f
  for f in "$dir"/log/*; do
    [ -f "$f" ] || continue
    echo "---- $f (last 20 lines)" >&2
    tail -n 20 "$f" >&2
  done
}

do_start() {
  need_tools
  if [ -f "$marker" ] && is_up; then
    log "already running in $dir"
    echo "export SLURM_CONF=$conf"
    return 0
  fi
  [ ! -e "$dir" ] || do_stop  # leftovers of a cluster that died: start afresh
  local host ctld_port d_port pid state
  host="$(uname -n)"; host="${host%%.*}"
  mkdir -p -- "$dir"
  chmod 0711 "$dir"  # munged wants every directory above its socket to be searchable by all
  : > "$marker"
  mkdir -p "$dir/etc" "$dir/state" "$dir/spool" "$dir/log" "$dir/run/munge" "$dir/munge-key"
  chmod 0700 "$dir/munge-key" "$dir/state" "$dir/spool"
  chmod 0755 "$dir/run" "$dir/run/munge"
  (umask 077 && head -c 1024 /dev/urandom > "$dir/munge-key/munge.key")
  chmod 0400 "$dir/munge-key/munge.key"
  # Two starts at once (ctest -j runs Slurm tests side by side) could pick the same free port:
  # both look before either binds. One start at a time picks its ports and holds this lock
  # until its daemons have bound them (the node is idle); the daemons do not inherit it (9>&-).
  exec 9> "${TMPDIR:-/tmp}/fragsim-slurm-local.lock"
  flock -w 120 9 || log "another start held the port lock for 120 s; going on without it"
  ctld_port="$(free_port)"
  d_port="$(free_port "$ctld_port")"
  write_conf "$host" "$ctld_port" "$d_port"

  # munged forks into the background itself and writes its pid file.
  if ! munged --key-file="$dir/munge-key/munge.key" --socket="$dir/run/munge/munge.socket" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/run/munged.seed" < /dev/null > "$dir/log/munged.out" 2>&1 9>&-; then
    log "munged did not start: $(cat "$dir/log/munged.out")"
    show_logs
    do_stop
    exit 1
  fi
  if ! munge -S "$dir/run/munge/munge.socket" -n < /dev/null |
    unmunge -S "$dir/run/munge/munge.socket" > /dev/null 2>&1; then
    log "munge credential round trip failed"
    show_logs
    do_stop
    exit 1
  fi
  # The Slurm daemons in the foreground (-D) of their own sessions, with no terminal and no pipe
  # of the caller's held open (a test runner waiting on our stdout must not wait for them).
  export SLURM_CONF="$conf"
  setsid slurmctld -D -i -f "$conf" < /dev/null > "$dir/log/slurmctld.out" 2>&1 9>&- &
  echo $! > "$dir/run/slurmctld.pid"
  for _ in $(seq 1 100); do
    timeout 5 scontrol ping > /dev/null 2>&1 && break
    sleep 0.1
  done
  setsid slurmd -D -f "$conf" -N "$host" < /dev/null > "$dir/log/slurmd.out" 2>&1 9>&- &
  echo $! > "$dir/run/slurmd.pid"
  for _ in $(seq 1 $((START_TIMEOUT_S * 2))); do
    for pid in slurmctld slurmd; do
      if ! our_pid "$dir/run/$pid.pid" > /dev/null; then
        log "$pid exited during start-up"
        show_logs
        do_stop
        exit 1
      fi
    done
    state="$(timeout 5 sinfo -h -N -o '%T' 2>/dev/null || true)"
    state="${state%%$'\n'*}"
    if [ "$state" = "idle" ]; then
      log "up in $dir: node $host, $(nproc) CPUs, partition $partition," \
        "slurmctld port $ctld_port, slurmd port $d_port"
      exec 9>&-  # the ports are bound: the next start may look
      echo "export SLURM_CONF=$conf"
      return 0
    fi
    sleep 0.5
  done
  log "node not idle after $START_TIMEOUT_S s (state: '${state:-none}')"
  show_logs
  do_stop
  exit 1
}

case "$cmd" in
  start) do_start ;;
  stop) do_stop ;;
  status)
    if [ -f "$marker" ] && is_up; then
      SLURM_CONF="$conf" sinfo >&2
      echo "export SLURM_CONF=$conf"
    else
      log "not running in $dir"
      exit 1
    fi
    ;;
  env) echo "export SLURM_CONF=$conf" ;;
esac
