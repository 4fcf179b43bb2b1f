#!/usr/bin/env bash
# A single-node Slurm cluster on this machine (Debian/Ubuntu, as root), for testing
# `hydrofrac sweep slurm --submit` (tests/sweep.rs, docs/sweep.md):
#   1. installs slurm-wlm and munge when sbatch or slurmctld is missing (apt-get);
#   2. writes a munge key and a minimal /etc/slurm/slurm.conf (one node: this host, its CPUs
#      and memory, one partition `debug`; select/cons_tres, proctrack/linuxproc, no
#      accounting) unless the config already names this host;
#   3. starts munged, slurmctld and slurmd as daemons when they are not running;
#   4. waits (up to 60 s) until `sinfo` shows the node idle (or mixed/allocated).
# Idempotent: run it again and it changes nothing on a running cluster. Prints what it does.
set -euo pipefail

if [[ $(id -u) -ne 0 ]]; then
    echo "slurm-single-node.sh: run as root (it installs packages and starts daemons)" >&2
    exit 1
fi

if ! command -v sbatch >/dev/null 2>&1 || ! command -v slurmctld >/dev/null 2>&1 \
    || ! command -v slurmd >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
    echo "installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq slurm-wlm munge >/dev/null
fi

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
conf_dir=/etc/slurm
conf=$conf_dir/slurm.conf

# Munge: a key, its folders owned by munge.
mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
if [[ ! -s /etc/munge/munge.key ]]; then
    echo "writing /etc/munge/munge.key"
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
fi
chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
chmod 0700 /etc/munge /var/lib/munge /var/log/munge
chmod 0755 /run/munge
chmod 0400 /etc/munge/munge.key
if ! pgrep -x munged >/dev/null; then
    echo "starting munged"
    runuser -u munge -- /usr/sbin/munged
fi
for _ in $(seq 50); do munge -n >/dev/null 2>&1 && break; sleep 0.1; done
munge -n | unmunge >/dev/null

# slurm.conf: written when missing or for another host.
mkdir -p "$conf_dir" /var/spool/slurmctld /var/spool/slurmd /var/log/slurm /run/slurm
if ! grep -qs "^NodeName=$host " "$conf"; then
    echo "writing $conf (node $host, $cpus CPUs, $mem_mb MB)"
    cat >"$conf" <<EOF
# A single-node cluster for tests, written by hydrofrac's scripts/slurm-single-node.sh.
ClusterName=hydrofrac-test
SlurmctldHost=$host
AuthType=auth/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurm/slurmctld.pid
SlurmdPidFile=/run/slurm/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=30
KillWait=10
Waittime=0
MaxArraySize=10001
NodeName=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    # The daemons read a changed file only at start.
    pkill -x slurmctld 2>/dev/null || true
    pkill -x slurmd 2>/dev/null || true
    sleep 1
fi
# No cgroup.conf: slurmd autodetects the cgroup plugin (Slurm 22.05 has no
# `CgroupPlugin=disabled`, and refuses to start with it).

if ! pgrep -x slurmctld >/dev/null; then
    echo "starting slurmctld"
    /usr/sbin/slurmctld
fi
if ! pgrep -x slurmd >/dev/null; then
    echo "starting slurmd"
    /usr/sbin/slurmd
fi

for _ in $(seq 120); do
    state=$(sinfo -h -n "$host" -o %T 2>/dev/null | head -1 || true)
    case $state in
        idle | mixed | allocated | completing)
            echo "slurm: node $host is $state"
            exit 0
            ;;
        down* | drain* | unknown*)
            scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true
            ;;
    esac
    sleep 0.5
done
echo "slurm-single-node.sh: node $host did not come up (sinfo: ${state:-nothing}); see /var/log/slurm/" >&2
exit 1
