#!/usr/bin/env bash
# A split preprocess on a real batch scheduler: a one-node Slurm on this
# machine runs the shards as one array job and the merge as a job that
# depends on it, and the scene must be byte-identical to the one-process
# build of the same model.
#
#   benches/slurm-preprocess.sh [MODEL...]
#
# Without MODEL it generates a 1M-triangle plant. Needs root (it installs
# Debian's slurm-wlm and munge when missing, and runs munged, slurmctld and
# slurmd), and stops what it started when it ends. On a real cluster the
# same three commands run as the docs say (docs/preprocess.md, "On a
# cluster"): the work directory must be on storage every node shares.
#
# Environment: GIGAWALK_BIN (default target/release/gigawalk), WORK (default
# a new directory under /tmp), SHARD_TRIANGLES (default 200k, so a small
# model still makes several shards).
set -euo pipefail

G=$(realpath "${GIGAWALK_BIN:-target/release/gigawalk}")
WORK=${WORK:-$(mktemp -d /tmp/gigawalk-slurm-XXXXXX)}
SHARD_TRIANGLES=${SHARD_TRIANGLES:-200k}
mkdir -p "$WORK"
WORK=$(realpath "$WORK")
# munged runs as the munge user: it must reach its files under WORK.
chmod 755 "$WORK"
say() { echo "[slurm-preprocess $(date +%T)] $*" >&2; }

if [ "$(id -u)" != 0 ]; then
    echo "error: run as root (it installs and starts munge and Slurm)" >&2
    exit 1
fi
if [ ! -x "$G" ]; then
    echo "error: no gigawalk binary at $G (cargo build --release, or set GIGAWALK_BIN)" >&2
    exit 1
fi

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    say "installing slurm-wlm and munge"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q slurm-wlm munge >&2
fi

# Everything this script starts, stopped however it ends.
PIDS=()
cleanup() {
    set +e
    [ -n "${ARRAY:-}" ] && scancel "$ARRAY" "${MERGE:-}" 2>/dev/null
    for f in "$WORK/slurm/slurmd.pid" "$WORK/slurm/slurmctld.pid" "$WORK/munge/munged.pid"; do
        [ -f "$f" ] && kill "$(cat "$f")" 2>/dev/null
    done
    for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done
    sleep 1
}
trap cleanup EXIT

# munge: a random key, its own socket and state under WORK.
mkdir -p "$WORK/munge" "$WORK/slurm/state" "$WORK/slurm/spool"
chown munge:munge "$WORK/munge"
chmod 700 "$WORK/munge"
dd if=/dev/urandom of="$WORK/munge/munge.key" bs=1024 count=1 status=none
chown munge:munge "$WORK/munge/munge.key"
chmod 400 "$WORK/munge/munge.key"
SOCKET="$WORK/munge/munge.socket"
runuser -u munge -- munged --key-file="$WORK/munge/munge.key" --socket="$SOCKET" \
    --pid-file="$WORK/munge/munged.pid" --log-file="$WORK/munge/munged.log" \
    --seed-file="$WORK/munge/munged.seed" --force
say "munged started"

HOST=$(hostname -s)
export SLURM_CONF="$WORK/slurm/slurm.conf"
cat > "$SLURM_CONF" <<EOF
ClusterName=gigawalk
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$SOCKET
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
StateSaveLocation=$WORK/slurm/state
SlurmdSpoolDir=$WORK/slurm/spool
SlurmctldPidFile=$WORK/slurm/slurmctld.pid
SlurmdPidFile=$WORK/slurm/slurmd.pid
SlurmctldLogFile=$WORK/slurm/slurmctld.log
SlurmdLogFile=$WORK/slurm/slurmd.log
NodeName=$HOST CPUs=$(nproc) State=UNKNOWN
PartitionName=main Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
    sinfo -h -o %T 2>/dev/null | grep -qE '^idle' && break
    sleep 1
done
sinfo -h -o %T | grep -qE '^idle' || {
    echo "error: the Slurm node did not come up; logs in $WORK/slurm" >&2
    exit 1
}
say "slurm is up: $(sinfo -h -o '%P %D %T %c')"

if [ $# -eq 0 ]; then
    say "generating a 1M-triangle plant"
    "$G" generate plant --triangles 1M --seed 1 -o "$WORK/plant.glb" >&2
    set -- "$WORK/plant.glb"
fi

DIR="$WORK/work"
N=$("$G" preprocess "$@" --work-dir "$DIR" --plan-only --shard-triangles "$SHARD_TRIANGLES")
say "plan: $N shards in $DIR/plan.json"

T0=$(date +%s.%N)
ARRAY=$(sbatch --parsable --array=0-$((N - 1)) --cpus-per-task=1 \
    --output="$WORK/shard-%a.log" --job-name=gigawalk-shards \
    --wrap="'$G' preprocess --work-dir '$DIR' --shard \$SLURM_ARRAY_TASK_ID")
MERGE=$(sbatch --parsable --dependency=afterok:"$ARRAY" --kill-on-invalid-dep=yes \
    --output="$WORK/merge.log" --job-name=gigawalk-merge \
    --wrap="'$G' preprocess --work-dir '$DIR' --merge -o '$WORK/slurm.gwk'")
say "submitted array job $ARRAY ($N tasks) and merge job $MERGE (afterok)"
while squeue -h -j "$ARRAY,$MERGE" 2>/dev/null | grep -q .; do
    sleep 2
done
T1=$(date +%s.%N)
if [ ! -f "$WORK/slurm.gwk" ]; then
    echo "error: the merge job wrote no scene; see $WORK/merge.log and $WORK/shard-*.log" >&2
    tail -5 "$WORK/merge.log" >&2 || true
    exit 1
fi
say "slurm build: $(awk "BEGIN { printf \"%.1f\", $T1 - $T0 }") s"

"$G" preprocess "$@" -o "$WORK/one.gwk" > "$WORK/one.log" 2>&1
T2=$(date +%s.%N)
say "one-process build: $(awk "BEGIN { printf \"%.1f\", $T2 - $T1 }") s"
if cmp "$WORK/slurm.gwk" "$WORK/one.gwk"; then
    say "byte-identical: $WORK/slurm.gwk = $WORK/one.gwk ($(stat -c %s "$WORK/one.gwk") bytes)"
else
    echo "error: the Slurm build differs from the one-process build" >&2
    exit 1
fi
