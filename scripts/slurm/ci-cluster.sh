#!/usr/bin/env bash
# A throw-away one-node Slurm cluster for CI and for trying the job scripts
# on one machine: no systemd, everything (config, state, logs, the munge
# socket) under one directory, daemons tracked by their pid files.
#
#   ci-cluster.sh start DIR   install slurm-wlm + munge if missing (apt-get,
#                             needs root), write DIR/slurm.conf, start munged,
#                             slurmctld and slurmd, wait until the node is idle;
#                             then `export SLURM_CONF=DIR/slurm.conf` to use it
#   ci-cluster.sh stop DIR    stop the daemons started from DIR (by pid file)
#
# A `start` first stops daemons left over from an earlier run in DIR. Ports:
# GIBAKE_SLURMCTLD_PORT (default 16817) and GIBAKE_SLURMD_PORT (16818), away
# from a real installation's 6817/6818. Exits non-zero with the daemons' log
# tails when the cluster does not come up: a test using it must fail then,
# never skip.
set -euo pipefail

cmd=${1:-}
dir=${2:-}
if [ -z "$cmd" ] || [ -z "$dir" ]; then
  echo "usage: $0 start|stop DIR" >&2
  exit 2
fi
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)

stop_pidfile() {
  local f=$1
  [ -f "$f" ] || return 0
  local pid
  pid=$(cat "$f" 2>/dev/null || true)
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 1 50); do
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -9 "$pid" 2>/dev/null || true
  fi
  rm -f "$f"
}

stop_all() {
  stop_pidfile "$dir/slurmd.pid"
  stop_pidfile "$dir/slurmctld.pid"
  stop_pidfile "$dir/munge/munged.pid"
}

if [ "$cmd" = stop ]; then
  stop_all
  echo "ci-cluster: stopped the daemons of $dir" >&2
  exit 0
fi
[ "$cmd" = start ] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

fail() {
  echo "ci-cluster: FAILED: $*" >&2
  for log in "$dir/munge/munged.log" "$dir/slurmctld.log" "$dir/slurmd.log"; do
    if [ -f "$log" ]; then
      echo "---- tail of $log" >&2
      tail -n 25 "$log" >&2
    fi
  done
  stop_all
  exit 1
}

# Install Slurm and munge when missing (Debian packages; root or sudo).
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || fail "slurm-wlm and munge are not installed and this is not root (no sudo)"
    SUDO=sudo
  fi
  echo "ci-cluster: installing slurm-wlm munge" >&2
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq || fail "apt-get update failed"
  $SUDO apt-get install -y -qq slurm-wlm munge >/dev/null || fail "apt-get install slurm-wlm munge failed"
fi
[ "$(id -u)" -eq 0 ] || fail "the one-node cluster runs its daemons as root (SlurmUser=root); run as root"

stop_all
rm -rf "$dir/state" "$dir/spool" "$dir/munge" "$dir"/*.log
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
chmod 700 "$dir/munge"

host=$(hostname -s)
cpus=$(nproc)
ctld_port=${GIBAKE_SLURMCTLD_PORT:-16817}
slurmd_port=${GIBAKE_SLURMD_PORT:-16818}
sock="$dir/munge/munge.socket"

# munge: own key, socket, pid and log file (leaves a system munged alone).
if command -v mungekey >/dev/null; then
  mungekey --create --keyfile="$dir/munge/munge.key" --force 2>/dev/null \
    || dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
else
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
fi
chmod 400 "$dir/munge/munge.key"
munged --force --key-file="$dir/munge/munge.key" --socket="$sock" \
  --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
  --seed-file="$dir/munge/munged.seed" || fail "munged did not start"
for _ in $(seq 1 50); do [ -S "$sock" ] && break; sleep 0.1; done
[ -S "$sock" ] || fail "munged made no socket at $sock"

cat >"$dir/slurm.conf" <<CONF
# Written by scripts/slurm/ci-cluster.sh: a one-node cluster for CI.
ClusterName=gibakeci
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
SwitchType=switch/none
MpiDefault=none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
MinJobAge=600
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1024 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"

slurmctld -f "$SLURM_CONF" -i || fail "slurmctld did not start"
died() { [ -f "$1" ] && ! kill -0 "$(cat "$1" 2>/dev/null)" 2>/dev/null; }
for _ in $(seq 1 100); do
  scontrol ping 2>/dev/null | grep -q UP && break
  died "$dir/slurmctld.pid" && fail "slurmctld exited"
  sleep 0.2
done
scontrol ping 2>/dev/null | grep -q UP || fail "slurmctld does not answer (scontrol ping)"
slurmd -f "$SLURM_CONF" -N "$host" || fail "slurmd did not start"

# Wait for the node to be idle (bounded).
state=""
for _ in $(seq 1 150); do
  died "$dir/slurmd.pid" && fail "slurmd exited"
  state=$(sinfo -h -N -n "$host" -o %T 2>/dev/null | head -n 1 || true)
  case "$state" in
    idle*) break ;;
  esac
  sleep 0.2
done
case "$state" in
  idle*) ;;
  *) fail "node $host is '${state:-unknown}', not idle" ;;
esac
echo "ci-cluster: one-node cluster up (node $host, $cpus CPUs); export SLURM_CONF=$SLURM_CONF" >&2
