#!/usr/bin/env bash
# Submits a sharded gibake bake to Slurm: a job array of N shard tasks
# (bake-shard.sbatch) and a merge job that runs after all of them succeeded
# (merge.sbatch, --dependency=afterok). Prints "ARRAY_JOB_ID MERGE_JOB_ID".
#
#   scripts/slurm/submit.sh [--wait] SCENE OUT.gibake N [bake flags...]
#
# The bake flags reach every shard exactly as given (an array: a quoted
# `--light "Key Light"` stays one argument). With --wait, submit.sh waits
# for the merge job and exits with its status: non-zero when a shard or the
# merge failed (a failed shard cancels the merge). Without it, it exits 0
# once both jobs are queued.
# Paths are made absolute and must be on a filesystem every node sees.
# Environment:
#   GIBAKE              gibake binary (default: gibake on PATH, made absolute)
#   GIBAKE_PARTS        parts directory (default: OUT.gibake.parts next to OUT)
#   GIBAKE_SBATCH_ARGS  extra sbatch flags for both jobs, e.g.
#                       "--partition=bake --cpus-per-task=16 --time=02:00:00"
#   GIBAKE_KEEP_PARTS   1 keeps the part files after the merge
set -euo pipefail
wait_flag=()
if [ "${1:-}" = --wait ]; then
  wait_flag=(--wait)
  shift
fi
if [ $# -lt 3 ]; then
  sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
abs() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
scene=$(abs "$1")
out=$(abs "$2")
n=$3
shift 3
case "$n" in
  '' | *[!0-9]*) echo "submit.sh: N must be a whole number, got '$n'" >&2; exit 2 ;;
esac
[ "$n" -ge 1 ] || { echo "submit.sh: N must be at least 1" >&2; exit 2; }
[ -f "$scene" ] || { echo "submit.sh: $scene: no such scene" >&2; exit 2; }
gibake=${GIBAKE:-$(command -v gibake || true)}
[ -n "$gibake" ] || { echo "submit.sh: no gibake on PATH; set GIBAKE" >&2; exit 2; }
gibake=$(abs "$gibake")
parts=$(abs "${GIBAKE_PARTS:-$out.parts}")
mkdir -p "$parts"

export GIBAKE="$gibake" GIBAKE_SCENE="$scene" GIBAKE_PARTS="$parts" GIBAKE_SHARDS="$n"
export GIBAKE_OUT="$out"
# The bake flags go to the batch script as its arguments ("$@": one word
# each, never re-split), not through an environment variable.
unset GIBAKE_BAKE_ARGS
# shellcheck disable=SC2086 # GIBAKE_SBATCH_ARGS is a list of flags
array=$(sbatch --parsable --array="0-$((n - 1))" --output="$parts/slurm-%A_%a.out" \
  ${GIBAKE_SBATCH_ARGS:-} "$here/bake-shard.sbatch" "$@")
array=${array%%;*}
[ -n "$array" ] || { echo "submit.sh: sbatch gave no job id for the shard array" >&2; exit 1; }
if [ ${#wait_flag[@]} -gt 0 ]; then
  echo "$array (shards); waiting for the merge job" >&2
fi
status=0
# shellcheck disable=SC2086
merge=$(sbatch --parsable "${wait_flag[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --output="$parts/slurm-merge-%j.out" ${GIBAKE_SBATCH_ARGS:-} "$here/merge.sbatch") || status=$?
merge=${merge%%;*}
echo "$array $merge"
if [ "$status" != 0 ]; then
  echo "submit.sh: the sharded bake failed (merge job ${merge:-?} exit $status; see $parts/slurm-*.out)" >&2
  exit 1
fi
