#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for trying `iapsim sweep --slurm` and for its tests: munge,
# slurmctld and slurmd on 127.0.0.1 with their own ports, keys, state and logs in one folder, nothing
# installed system-wide (Debian's slurmctld, slurmd, slurm-client and munge; ../shared/NOTES.md "Slurm").
#
#   tools/slurm_local_cluster.sh start DIR   # prints `export SLURM_CONF=DIR/slurm.conf`; exit 1 if not up in 30 s
#   tools/slurm_local_cluster.sh stop DIR    # stops the three daemons by their pids (DIR/*.pid)
#
# One partition `local` with as many CPUs as the machine has; a run of a sweep takes cpus_per_run of them.
# The daemons run as the calling user (SlurmUser): root, or a user who only submits their own jobs.
set -euo pipefail

usage() { echo "usage: $0 start|stop DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
action=$1
dir=$(realpath -m "$2")

stop() {
  local name pid
  for name in slurmd slurmctld munged; do
    [ -f "$dir/$name.pid" ] || continue
    pid=$(cat "$dir/$name.pid")
    kill "$pid" 2> /dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2> /dev/null || true
    rm -f "$dir/$name.pid"
  done
  if [ -f "$dir/munge-socket-dir" ]; then
    rm -rf "$(cat "$dir/munge-socket-dir")"
    rm -f "$dir/munge-socket-dir"
  fi
}

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

start() {
  for tool in munged mungekey slurmctld slurmd sinfo; do
    command -v "$tool" > /dev/null || { echo "$0: $tool not found (apt-get install munge slurmctld slurmd slurm-client)" >&2; exit 1; }
  done
  mkdir -p "$dir"/{munge,state,spool}
  chmod 0700 "$dir/munge"
  [ -f "$dir/munge/munge.key" ] || mungekey --create --keyfile="$dir/munge/munge.key"
  # munged wants every folder above its socket open to all, which DIR's (a mktemp -d, say) may not be
  local socket_dir
  socket_dir=$(mktemp -d /tmp/iapsim-munge.XXXXXX)
  chmod 0755 "$socket_dir"
  echo "$socket_dir" > "$dir/munge-socket-dir"
  local socket=$socket_dir/munge.socket
  munged --socket="$socket" --key-file="$dir/munge/munge.key" --pid-file="$dir/munged.pid" \
    --log-file="$dir/munged.log" --seed-file="$dir/munge/munge.seed"

  local host user cpus
  host=$(hostname -s)
  user=$(id -un)
  cpus=$(nproc)
  cat > "$dir/slurm.conf" << EOF
ClusterName=iapsim-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
SchedulerParameters=sched_min_interval=0
MessageTimeout=10
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$SLURM_CONF"
  slurmd -f "$SLURM_CONF"
  for _ in $(seq 300); do
    if sinfo -h -o %t 2> /dev/null | grep -q '^idle'; then
      echo "export SLURM_CONF=$SLURM_CONF"
      return 0
    fi
    sleep 0.1
  done
  echo "$0: the node did not come up in 30 s; logs in $dir" >&2
  sinfo >&2 || true
  stop
  exit 1
}

case $action in
  start) start ;;
  stop) stop ;;
  *) usage ;;
esac
