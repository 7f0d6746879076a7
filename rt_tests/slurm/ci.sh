#!/usr/bin/env bash
# The Slurm batch scripts (config/slurm) on a real Slurm: a one-node cluster on localhost
# (munged, slurmctld, slurmd, every daemon bound to 127.0.0.1, run as root from a private
# directory), the array job of a small bench (the paper scenes x 3 planners x 1 seed, 320x240,
# 4 shards), its merge job, then the same bench unsharded: every metrics.json, and the merged
# report's tables, must be identical byte for byte (issue 46).
#   rt_tests/slurm/ci.sh VPSOM_BINARY [WORK_DIR]
# Installs Debian's slurm-wlm and munge when missing (root and apt-get). Under CI=true a
# Slurm that cannot be installed or started fails the step; elsewhere it is skipped, with the
# reason on stdout. A bench that differs fails everywhere.
set -euo pipefail
vpsom=$(realpath "${1:?usage: $0 VPSOM_BINARY [WORK_DIR]}")
work=${2:-target/ci-slurm}
repo=$(cd "$(dirname "$0")/../.." && pwd)
shards=4
start=$(date +%s)

unavailable() {
  if [ "${CI:-}" = true ]; then
    echo "FAILED slurm: $* (CI=true: this step never skips)" >&2
    exit 1
  fi
  echo "SKIPPED slurm: $*"
  exit 0
}

if ! command -v sbatch >/dev/null || ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
  || ! command -v munged >/dev/null; then
  if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
    unavailable "slurm-wlm or munge is not installed, and installing needs root and apt-get"
  fi
  echo "installing slurm-wlm and munge"
  timeout 600 bash -c 'apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge' \
    >/dev/null 2>&1 || unavailable "apt-get install slurm-wlm munge failed"
fi
[ "$(id -u)" = 0 ] || unavailable "the one-node cluster runs its daemons as root (SlurmUser=root)"

rm -rf "$work"
mkdir -p "$work"
work=$(cd "$work" && pwd)
mkdir -p "$work"/{munge-key,munge,state/ctld,state/d,log}
chmod 700 "$work/munge-key"
chmod 755 "$work/munge"
dd if=/dev/urandom of="$work/munge-key/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge-key/munge.key"

pids=()
cleanup() {
  # Only the daemons this script started, by their pids.
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
  done
}
trap cleanup EXIT

munged -F -f --socket="$work/munge/munge.socket" --key-file="$work/munge-key/munge.key" \
  --pid-file="$work/munge/munged.pid" --seed-file="$work/munge/munged.seed" \
  --log-file="$work/log/munged.log" >"$work/log/munged.out" 2>&1 &
pids+=($!)

# Ports away from Slurm's defaults (6817/6818), so that a system Slurm is never touched.
port=${VPSOM_SLURM_PORT:-16817}
touch "$work/plugstack.conf"
cat >"$work/slurm.conf" <<CONF
# One-node Slurm on localhost for rt_tests/slurm/ci.sh (written by it; see docs/cluster.md).
ClusterName=vpsomci
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
# Bind every daemon to the address its host name resolves to (127.0.0.1), not to all addresses.
CommunicationParameters=NoCtldInAddrAny,NoInAddrAny
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge/munge.socket
StateSaveLocation=$work/state/ctld
SlurmdSpoolDir=$work/state/d
SlurmctldPidFile=$work/state/slurmctld.pid
SlurmdPidFile=$work/state/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
PlugStackConfig=$work/plugstack.conf
MailProg=/bin/true
# No cgroups (a container-like VM): processes are tracked through /proc, tasks not bound.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
NodeName=localhost NodeHostname=localhost NodeAddr=127.0.0.1 CPUs=2 Sockets=1 CoresPerSocket=2 ThreadsPerCore=1 RealMemory=1000 State=UNKNOWN
PartitionName=ci Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"

for _ in $(seq 50); do [ -S "$work/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$work/munge/munge.socket" ] || unavailable "munged did not start: $(tail -3 "$work/log/munged.out")"
slurmctld -D -f "$SLURM_CONF" >"$work/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N localhost >"$work/log/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 60); do
  state=$(sinfo -h -n localhost -o %T 2>/dev/null || true)
  [ "$state" = idle ] && break
  sleep 1
done
[ "$state" = idle ] || unavailable "the node is not idle after 60 s (state '$state'): $(tail -3 "$work/log/slurmctld.log" "$work/log/slurmd.log" 2>&1)"
echo "slurm: one-node cluster up in $(( $(date +%s) - start )) s ($(sinfo -V))"

# The bench: the paper scenes x vpsom, coverage, frontier x seed 1, at 320x240.
cat >"$work/bench.toml" <<CONF
# Merged over config/default.toml: the CI's small bench (rt_tests/slurm/ci.sh).
[bench]
camera_width = 320
camera_height = 240
seeds = 1
CONF
args=(--config "$work/bench.toml")

t=$(date +%s)
ids=$(VPSOM="$vpsom" SBATCH_ARGS="--cpus-per-task=1" "$repo/config/slurm/submit.sh" "$shards" "$work/sharded" "${args[@]}")
echo "$ids"
merge=$(sed -n 's/.*merge: job \([0-9]*\).*/\1/p' <<<"$ids")
[ -n "$merge" ] || { echo "FAILED slurm: no merge job id in '$ids'" >&2; exit 1; }
job_state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1; }
for _ in $(seq 600); do
  s=$(job_state "$merge")
  case $s in COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY) break ;; esac
  sleep 1
done
echo "slurm: sharded bench and merge: $s in $(( $(date +%s) - t )) s"
if [ "$s" != COMPLETED ]; then
  echo "FAILED slurm: the merge job ended $s" >&2
  tail -n 20 "$work"/sharded/slurm/*.out >&2 || true
  exit 1
fi

t=$(date +%s)
"$vpsom" bench "${args[@]}" --jobs 2 --out "$work/whole" >"$work/log/whole.out" 2>&1 \
  || { cat "$work/log/whole.out" >&2; echo "FAILED slurm: the unsharded bench failed" >&2; exit 1; }
echo "slurm: unsharded bench in $(( $(date +%s) - t )) s"

# metrics.json holds no wall-clock field: every file must be equal byte for byte.
(cd "$work/whole" && find . -name metrics.json | sort) >"$work/whole.list"
(cd "$work/sharded" && find . -name metrics.json | sort) >"$work/sharded.list"
runs=$(wc -l <"$work/whole.list")
[ "$runs" = 9 ] || { echo "FAILED slurm: the unsharded bench wrote $runs metrics.json, not 9" >&2; exit 1; }
diff "$work/whole.list" "$work/sharded.list" >&2 || { echo "FAILED slurm: the sharded bench wrote other runs" >&2; exit 1; }
while read -r f; do
  cmp "$work/whole/$f" "$work/sharded/$f" >&2 || { echo "FAILED slurm: $f differs" >&2; exit 1; }
done <"$work/whole.list"
for f in report.md table1.csv table2.csv health.csv diagnosis.csv; do
  cmp "$work/whole/$f" "$work/sharded/$f" >&2 || { echo "FAILED slurm: the merged $f differs" >&2; exit 1; }
done
echo "slurm: $runs metrics.json and the merged report identical to the unsharded bench's ($(( $(date +%s) - start )) s in all)"
