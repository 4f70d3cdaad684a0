#!/usr/bin/env bash
# A one-node SLURM cluster in a directory of its own, without systemd, for tests: munged with its own
# key and socket, slurmctld and slurmd with a generated slurm.conf (this host's name, CPUs and
# memory as `slurmd -C` reports them; free ports on 127.0.0.1; no cgroups, no accounting). Every
# state, spool, log, pid and socket file is inside DIR; nothing under /etc or /run is touched.
# Installs the Debian packages (slurmctld slurmd slurm-client munge) if missing. Needs root: slurmd
# starts jobs, munged and the daemons run as the current user (SlurmUser).
#
# Sourced, in a test script:
#   source tests/study/slurm_cluster.sh
#   slurm_cluster_start DIR          # exports SLURM_CONF=DIR/slurm.conf
#   sbatch ...
#   slurm_cluster_stop DIR
# Run, from a shell:
#   eval "$(tests/study/slurm_cluster.sh start DIR)"   # prints: export SLURM_CONF=DIR/slurm.conf
#   sbatch ...
#   tests/study/slurm_cluster.sh stop DIR
# DIR must not exist or be empty, and it and its parents must be searchable by all (munged checks
# that of its socket's path; `mktemp -d` makes 0700: chmod 755 it). Stop kills the daemons by their
# PIDs and removes DIR.
# On a failed start, the daemons' logs are shown and whatever was started is stopped again.

source "$(cd "$(dirname "${BASH_SOURCE[0]}")/../../scripts" && pwd)/common.sh"

SLURM_CLUSTER_PACKAGES=(slurmctld slurmd slurm-client munge)

# _slurm_free_port [EXCEPT]: a TCP port that nothing listens on (and that is not EXCEPT).
_slurm_free_port() {
  local used port
  used=" $(ss -Htan | awk '{ n = split($4, a, ":"); printf "%s ", a[n] }') ${1:-} "
  for _ in $(seq 1 100); do
    port=$((20000 + RANDOM % 40000))
    [[ "$used" == *" $port "* ]] || { echo "$port"; return 0; }
  done
  echo "slurm_cluster: no free TCP port found" >&2
  return 1
}

# _slurm_alive PIDFILE: the process named in PIDFILE runs.
_slurm_alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

# _slurm_kill PIDFILE...: TERM the processes named in the PIDFILEs, KILL those left after 10 s.
_slurm_kill() {
  local f pids=()
  for f in "$@"; do
    _slurm_alive "$f" && pids+=("$(cat "$f")")
  done
  [ ${#pids[@]} -gt 0 ] || return 0
  kill -TERM "${pids[@]}" 2>/dev/null || true
  _slurm_wait_for 10 _slurm_none_alive "${pids[@]}" && return 0
  for f in "${pids[@]}"; do
    kill -0 "$f" 2>/dev/null || continue
    echo "slurm_cluster: pid $f ($(cat "/proc/$f/comm" 2>/dev/null)) ignored TERM, killing it" >&2
    kill -KILL "$f" 2>/dev/null || true
  done
}

_slurm_none_alive() {
  local pid
  for pid in "$@"; do
    ! kill -0 "$pid" 2>/dev/null || return 1
  done
}

# _slurm_logs DIR: the daemons' logs, to stderr.
_slurm_logs() {
  local log
  for log in "$1/log/munged.log" "$1/log/slurmctld.log" "$1/log/slurmd.log"; do
    [ -s "$log" ] || continue
    echo "---- $log (last 40 lines)" >&2
    tail -n 40 "$log" >&2
  done
}

# _slurm_fail DIR MESSAGE: report MESSAGE with the logs, stop what was started, return 1.
_slurm_fail() {
  echo "slurm_cluster: $2" >&2
  _slurm_logs "$1"
  slurm_cluster_stop "$1"
  return 1
}

# _slurm_wait_for SECONDS COMMAND...: COMMAND succeeds within SECONDS.
_slurm_wait_for() {
  local tries=$(($1 * 10))
  shift
  for _ in $(seq 1 "$tries"); do
    "$@" && return 0
    sleep 0.1
  done
  return 1
}

_slurm_node_ready() {
  local state
  state="$(sinfo -h -n "$SLURM_CLUSTER_HOST" -o %T 2>/dev/null)" || return 1
  [ "$state" = idle ] || [ "$state" = mixed ] || [ "$state" = allocated ]
}

_slurm_no_job_running() { [ -z "$(squeue -h -t running,completing -o %i 2>/dev/null)" ]; }

# slurm_cluster_start DIR: start the cluster in DIR, wait until its node is idle, export SLURM_CONF.
slurm_cluster_start() {
  local dir="$1"
  if [ -e "$dir" ] && [ -n "$(ls -A "$dir")" ]; then
    echo "slurm_cluster: $dir exists and is not empty" >&2
    return 1
  fi
  ensure_packages "${SLURM_CLUSTER_PACKAGES[@]}"
  mkdir -p "$dir"/{munge,state,spool,log}
  dir="$(cd "$dir" && pwd)"
  # munged refuses a socket directory that others may write to; clients must reach the socket.
  chmod 755 "$dir" "$dir/munge"
  local socket="$dir/munge/munge.socket"
  if [ ${#socket} -ge 100 ]; then
    echo "slurm_cluster: $socket is too long for a Unix socket; use a shorter DIR (TMPDIR)" >&2
    return 1
  fi

  # munge: its own key, socket, pid, seed and log file.
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$dir/munge/munge.key"
  if ! munged --socket="$socket" --key-file="$dir/munge/munge.key" --log-file="$dir/log/munged.log" \
              --pid-file="$dir/munge/munged.pid" --seed-file="$dir/munge/munged.seed" 2>"$dir/log/munged.err"; then
    cat "$dir/log/munged.err" >&2
    _slurm_fail "$dir" "munged did not start"
    return 1
  fi

  # slurm.conf: the node as slurmd sees it (CPUs, sockets, cores, threads, memory), so it is not drained.
  SLURM_CLUSTER_HOST="$(hostname -s)"
  local node ctld_port slurmd_port user
  node="$(slurmd -C | grep '^NodeName=')" || { _slurm_fail "$dir" "slurmd -C failed"; return 1; }
  ctld_port="$(_slurm_free_port)" || { _slurm_fail "$dir" "no free port for slurmctld"; return 1; }
  slurmd_port="$(_slurm_free_port "$ctld_port")" || { _slurm_fail "$dir" "no free port for slurmd"; return 1; }
  user="$(id -un)"
  cat >"$dir/slurm.conf" <<EOF
# Generated by tests/study/slurm_cluster.sh: a one-node test cluster, everything under $dir.
ClusterName=alc-test
SlurmctldHost=$SLURM_CLUSTER_HOST(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# A job whose dependency can no longer be met (a shard failed) is cancelled instead of pending forever.
SchedulerParameters=kill_invalid_depend
ReturnToService=2
InactiveLimit=0
MailProg=/bin/true
KillWait=5
MinJobAge=300
Waittime=0
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="$dir/slurm.conf"

  slurmctld -f "$SLURM_CONF" 2>"$dir/log/slurmctld.err" || { cat "$dir/log/slurmctld.err" >&2; _slurm_fail "$dir" "slurmctld did not start"; return 1; }
  slurmd -f "$SLURM_CONF" 2>"$dir/log/slurmd.err" || { cat "$dir/log/slurmd.err" >&2; _slurm_fail "$dir" "slurmd did not start"; return 1; }
  if ! _slurm_wait_for 30 _slurm_node_ready; then
    _slurm_fail "$dir" "node $SLURM_CLUSTER_HOST not idle after 30 s (sinfo: $(sinfo -h -o '%N %T' 2>&1 | tr '\n' ' '))"
    return 1
  fi
}

# slurm_cluster_stop DIR: cancel the jobs, stop slurmd, slurmctld and munged by their PIDs, remove DIR.
# Does nothing to a DIR that has no cluster's files (never removes a directory it did not make).
slurm_cluster_stop() {
  local dir="$1"
  [ -d "$dir/munge" ] && [ -d "$dir/spool" ] || return 0
  if _slurm_alive "$dir/slurmctld.pid"; then
    # Running jobs' slurmstepd would outlive slurmd: cancel them and wait for the queue to drain.
    local -x SLURM_CONF="$dir/slurm.conf"
    scancel --user="$(id -un)" 2>/dev/null || true
    _slurm_wait_for 15 _slurm_no_job_running || echo "slurm_cluster: jobs still running in $dir after scancel" >&2
  fi
  _slurm_kill "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"
  rm -rf "$dir"
}

if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  case "${1:-} ${2:+dir}" in
    "start dir") slurm_cluster_start "$2" >&2 && echo "export SLURM_CONF=$SLURM_CONF" ;;
    "stop dir") slurm_cluster_stop "$2" ;;
    *) echo "usage: $0 start|stop DIR" >&2; exit 2 ;;
  esac
fi
