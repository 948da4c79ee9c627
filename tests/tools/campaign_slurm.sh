#!/bin/bash
# SPDX-License-Identifier: BSD-3-Clause
# The campaign as a Slurm job array (issue 9): starts a throw-away one-node Slurm cluster on
# loopback (the recipe of shared/spec/slurm-single-node.md: a temp dir, SLURM_CONF, free ports,
# munged/slurmctld/slurmd in the foreground as direct children of this script, stopped by PID
# and always cleaned up), submits tools/slurm/campaign.sbatch as an array of M shards, waits
# (squeue polling, with a timeout), merges, and checks that the merge equals the one-process run
# of the campaign_shards fixture: the same rows (sorted by index, without the two wall-clock
# step-time columns) and the same merged counts, also after task 2 was lost and re-run alone.
# Usage: campaign_slurm.sh ADIT MAP SBATCH_SCRIPT OUT N SEED M REFERENCE_DIR GENERATOR
set -euo pipefail
ADIT=$1 MAP=$2 SCRIPT=$3 OUT=$4 N=$5 SEED=$6 M=$7 REF=$8 GENERATOR=$9

T=$(mktemp -d /tmp/adit-slurm-test.XXXXXX)
chmod 755 "$T"  # munged needs o+x on its socket's directories
mkdir -p "$T"/{munge,state,spool,log,out}
PIDS=()
cleanup() {
  local rc=$?
  for ((i = ${#PIDS[@]} - 1; i >= 0; i--)); do kill -TERM "${PIDS[i]}" 2>/dev/null || true; done
  for p in "${PIDS[@]}"; do wait "$p" 2>/dev/null || true; done
  if [ $rc -ne 0 ]; then
    for f in "$T"/log/* "$T"/out/*; do [ -f "$f" ] && { echo "--- $f"; tail -n 20 "$f"; }; done >&2
  fi
  rm -rf "$T"
  exit $rc
}
trap cleanup EXIT
export SLURM_CONF=$T/slurm.conf

# Two free loopback ports: nothing listens there now (a clash later is caught by the liveness check).
listening() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
free_port() {
  local p
  for _ in $(seq 100); do
    p=$((20000 + RANDOM % 40000))
    listening "$p" || listening $((p + 1)) || { echo "$p"; return; }
  done
  echo "no free port" >&2
  return 1
}
PORT=$(free_port)

mungekey -c -k "$T/munge/munge.key"
munged -F -S "$T/munge/munge.sock" --key-file="$T/munge/munge.key" --pid-file="$T/munge/munged.pid" \
  --seed-file="$T/munge/munged.seed" 2>"$T/log/munged.log" &
PIDS+=($!)
for _ in $(seq 50); do [ -S "$T/munge/munge.sock" ] && break; sleep 0.1; done
[ -S "$T/munge/munge.sock" ] || { echo "munged did not start" >&2; exit 1; }

NODE=$(slurmd -C | head -1 | sed -e 's/^NodeName=[^ ]*/NodeName=localhost/' -e 's/RealMemory=[0-9]*/RealMemory=1000/')
U=$(id -un)
cat >"$SLURM_CONF" <<EOF
ClusterName=adittest
SlurmctldHost=localhost
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
SlurmUser=$U
SlurmdUser=$U
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$T/munge/munge.sock
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
MailProg=/bin/true
$NODE NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -f "$SLURM_CONF" >"$T/log/slurmctld.stdout" 2>&1 &
PIDS+=($!)
slurmd -D -f "$SLURM_CONF" -N localhost >"$T/log/slurmd.stdout" 2>&1 &
PIDS+=($!)
alive() { for p in "${PIDS[@]}"; do kill -0 "$p" 2>/dev/null || { echo "a Slurm daemon died (pid $p)" >&2; return 1; }; done; }
for _ in $(seq 300); do
  alive
  [ "$(sinfo -h -n localhost -o %T 2>/dev/null)" = idle ] && break
  sleep 0.1
done
[ "$(sinfo -h -n localhost -o %T)" = idle ] || { echo "the node did not become idle" >&2; exit 1; }

C=$OUT/campaign_slurm
rm -rf "$C"
mkdir -p "$C"
jid=$(ADIT=$ADIT sbatch --parsable --array=0-$((M - 1)) --cpus-per-task=1 -o "$T/out/%A_%a.out" \
  "$SCRIPT" "$MAP" "$N" "$SEED" "$M" "$C" -q --generator "$GENERATOR")
echo "submitted array job $jid ($M shards)"
deadline=$((SECONDS + 300))
while [ -n "$(squeue -h -j "$jid" 2>/dev/null)" ]; do
  alive
  [ $SECONDS -lt $deadline ] || { echo "the array did not finish in 300 s" >&2; exit 1; }
  sleep 0.2
done
cat "$T"/out/*.out
completed=$(scontrol -o show job "$jid" | grep -c JobState=COMPLETED || true)
[ "$completed" = "$M" ] || { scontrol -o show job "$jid" >&2; echo "$completed of $M tasks completed" >&2; exit 1; }

# A lost task (its files gone, as when it was killed before writing them): merge refuses, the
# task is re-run alone with --array=K, the other shards' files are left as they were.
rm "$C/shard-2-of-$M.json" "$C/shard-2-of-$M.csv"
if "$ADIT" campaign merge -q "$C" --out "$C/report.json" 2>"$T/merge.err"; then
  echo "merge accepted a campaign without shard 2" >&2; exit 1
fi
grep -q "missing shards.*shard-2-of-$M.json" "$T/merge.err" || { cat "$T/merge.err" >&2; exit 1; }
before=$(stat -c '%n %i %.9Y' "$C"/shard-*.json)
jid=$(ADIT=$ADIT sbatch --parsable --array=2 --cpus-per-task=1 -o "$T/out/%A_%a.out" \
  "$SCRIPT" "$MAP" "$N" "$SEED" "$M" "$C" -q --generator "$GENERATOR")
echo "re-submitted task 2 alone as job $jid"
while [ -n "$(squeue -h -j "$jid" 2>/dev/null)" ]; do
  alive
  [ $SECONDS -lt $deadline ] || { echo "task 2 did not finish in time" >&2; exit 1; }
  sleep 0.2
done
[ -f "$C/shard-2-of-$M.json" ] || { echo "task 2 re-run wrote no shard" >&2; exit 1; }
[ "$(stat -c '%n %i %.9Y' "$C"/shard-*.json | grep -v "shard-2-of")" = "$before" ] || { echo "other shards were rewritten" >&2; exit 1; }

"$ADIT" campaign merge -q "$C" --out "$C/report.json" --csv "$C/merged.csv"
rows() { tail -n +2 "$1" | cut -d, -f1-7 | sort -t, -k1,1n; }
counts() { sed -n '/"counts": {/,/^    }/p' "$1"; }
diff <(rows "$REF/shard-0-of-1.csv") <(rows "$C/merged.csv") || { echo "rows differ from the one-process run" >&2; exit 1; }
[ -n "$(counts "$REF/shard-0-of-1.json")" ] || { echo "no counts in $REF/shard-0-of-1.json" >&2; exit 1; }
diff <(counts "$REF/shard-0-of-1.json") <(counts "$C/report.json") || { echo "counts differ from the one-process run" >&2; exit 1; }
echo "the Slurm array's merge equals the one-process run:"
rows "$C/merged.csv"
