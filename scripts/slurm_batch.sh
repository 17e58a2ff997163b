#!/usr/bin/env bash
# A Slurm job array over an asset library: one `supermat batch` shard per array task, all writing below one
# shared OUT folder (a journal per shard), then one merge step.
#
#   export OUT=/shared/maps SUPERMAT=/opt/supermat/bin/supermat SHARDS=50
#   jid=$(sbatch --parsable --array=0-49 scripts/slurm_batch.sh /shared/library)
#   sbatch --dependency=afterany:$jid --wrap "$SUPERMAT batch --merge --out $OUT /shared/library"
#
# A task that dies (node lost, time limit, scancel) is resubmitted alone with the same SHARDS
# (`SHARDS=50 sbatch --array=7 scripts/slurm_batch.sh ...`): its journal skips what it finished. Without
# SHARDS the shard count is the array's size, which a resubmitted single task does not know. Extra
# `supermat batch image` options go in SUPERMAT_ARGS (e.g. --model F).
#SBATCH --job-name=supermat
#SBATCH --cpus-per-task=2
#SBATCH --output=supermat-%A_%a.log
set -euo pipefail
: "${SLURM_ARRAY_TASK_ID:?run it as a job array: sbatch --array=0-(N-1) $0 INPUT...}"
: "${OUT:?set OUT to the shared output folder}"
# the number of shards: SHARDS, else the array's size (Slurm sets SLURM_ARRAY_TASK_COUNT; older versions only MAX)
N=${SHARDS:-${SLURM_ARRAY_TASK_COUNT:-$((${SLURM_ARRAY_TASK_MAX:?} + 1))}}
# shellcheck disable=SC2086
exec "${SUPERMAT:-supermat}" batch image ${SUPERMAT_ARGS:-} --out "$OUT" --shard "$SLURM_ARRAY_TASK_ID/$N" \
    --threads "${SLURM_CPUS_PER_TASK:-0}" "$@"
