#!/usr/bin/env bash
# A Slurm job array over the shards of the timing sweep (experiments/lib/timing.hpp).
#
#   scripts/slurm_sweep.sh --submit N [--mode quick|full|tiny] [--build DIR] [--out-dir DIR]
#       submits an array of N tasks (task i runs shard i/N) and a dependent job that merges
#       the shard files into OUT_DIR/timing.h5 (sbatch options go in SBATCH_ARGS, e.g.
#       SBATCH_ARGS="--partition=cpu --time=02:00:00").
#   sbatch --array=0-(N-1) scripts/slurm_sweep.sh [--mode …] [--build DIR] [--out-dir DIR]
#       the array alone; then: DIR/minv merge --out OUT_DIR/timing.h5 OUT_DIR/shards/timing.*.h5
#
# Each task writes OUT_DIR/shards/timing.<i>of<N>.h5, point by point: a task that is killed
# (time limit, pre-emption) resumes where it stopped when resubmitted (sbatch --requeue works).
# Paths are relative to the submission directory (the repository root); defaults: --mode
# quick, --build build, --out-dir results. One CPU per task: the timings are single-threaded,
# except the `threads` family (Figure 3), which wants --cpus-per-task=4 for honest numbers.
#SBATCH --job-name=minv-timing
#SBATCH --cpus-per-task=1
#SBATCH --output=slurm-minv-%A_%a.out
set -euo pipefail
mode=quick build=build out_dir=results submit=0
while [ $# -gt 0 ]; do
  case "$1" in
    --mode) mode=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --out-dir) out_dir=$2; shift 2 ;;
    --submit) submit=$2; shift 2 ;;
    *) echo "slurm_sweep: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
cd "${SLURM_SUBMIT_DIR:-.}"
mkdir -p "$out_dir/shards"

if [ "$submit" -gt 0 ]; then
  self=$(readlink -f "$0")
  args=(--mode "$mode" --build "$build" --out-dir "$out_dir")
  # shellcheck disable=SC2086
  array=$(sbatch --parsable ${SBATCH_ARGS:-} --array=0-$((submit - 1)) "$self" "${args[@]}")
  # shellcheck disable=SC2086
  merge=$(sbatch --parsable ${SBATCH_ARGS:-} --dependency=afterok:"${array%%;*}" \
    --job-name=minv-merge --output="$out_dir/shards/merge-%j.out" \
    --wrap="$build/minv merge --out $out_dir/timing.h5 \$(ls $out_dir/shards/timing.*of${submit}.h5)")
  echo "slurm_sweep: array job $array ($submit shards), merge job $merge -> $out_dir/timing.h5"
  exit 0
fi

: "${SLURM_ARRAY_TASK_ID:?run under sbatch --array=0-(N-1), or use --submit N}"
count=${SLURM_ARRAY_TASK_COUNT:-1}
# Tasks index from the array's minimum (0 unless the user chose otherwise).
index=$((SLURM_ARRAY_TASK_ID - ${SLURM_ARRAY_TASK_MIN:-0}))
# (bench_timing sets OpenBLAS and OpenMP threads itself: 1, or t in the threads family.)
exec "$build/bench_timing" --mode "$mode" --shard "$index/$count" \
  --out "$out_dir/shards/timing.${index}of${count}.h5"
