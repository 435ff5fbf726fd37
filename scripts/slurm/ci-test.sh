#!/usr/bin/env bash
# The Slurm recipe, tested for real on one machine (tests/pipeline_slurm.rs
# runs it): start a one-node cluster (ci-cluster.sh), submit a 4-shard bake of
# a bundled scene with submit.sh (job array + merge job with
# --dependency=afterok), wait for the merge job, bake the scene once on this
# machine, and compare every file's bytes. Stops the cluster at the end.
#
#   scripts/slurm/ci-test.sh [GIBAKE_BINARY]
#
# Environment: GIBAKE_SLURM_DIR (cluster + work directory, default
# /tmp/gibake-slurm-ci), GIBAKE_SLURM_SCENE (default data/corner_bunny.glb),
# GIBAKE_SLURM_SHARDS (4), GIBAKE_SLURM_BAKE_ARGS (small, quick settings),
# GIBAKE_SLURM_TIMEOUT (seconds to wait for the jobs, 300).
# Exit 0 only when the merged asset is byte-identical; any failure to install
# or start Slurm is a failure, never a skip.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
gibake=${1:-${GIBAKE:-$root/target/release/gibake}}
[ -x "$gibake" ] || { echo "ci-test: $gibake is not an executable gibake" >&2; exit 1; }
dir=${GIBAKE_SLURM_DIR:-/tmp/gibake-slurm-ci}
scene=${GIBAKE_SLURM_SCENE:-$root/data/corner_bunny.glb}
n=${GIBAKE_SLURM_SHARDS:-4}
bake_args=${GIBAKE_SLURM_BAKE_ARGS:---rsm-size 128 --vpl-map-size 32 --vpls 64 --shadow-map-size 512}
timeout=${GIBAKE_SLURM_TIMEOUT:-300}

bash "$here/ci-cluster.sh" start "$dir"
export SLURM_CONF="$dir/slurm.conf"
trap 'bash "$here/ci-cluster.sh" stop "$dir"' EXIT

work="$dir/work"
rm -rf "$work"
mkdir -p "$work"
sharded="$work/sharded.gibake"
single="$work/single.gibake"

now() { date +%s.%N; }
t0=$(now)
# shellcheck disable=SC2086
read -r array merge < <(GIBAKE="$gibake" GIBAKE_PARTS="$work/parts" \
  "$here/submit.sh" "$scene" "$sharded" "$n" $bake_args)
echo "ci-test: submitted shard array job $array ($n tasks) and merge job $merge (afterok:$array)"

job_state() { scontrol show job "$1" -o 2>/dev/null | tr ' ' '\n' | sed -n 's/^JobState=//p' | head -n 1; }
show_logs() {
  for f in "$work"/parts/slurm-*.out; do
    [ -f "$f" ] && { echo "---- $f"; tail -n 20 "$f"; }
  done
  scontrol show job "$array" 2>/dev/null | grep -E "JobId|JobState|Reason" || true
}
deadline=$(( $(date +%s) + timeout ))
state=""
while :; do
  state=$(job_state "$merge")
  case "$state" in
    COMPLETED) break ;;
    FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE | PREEMPTED)
      echo "ci-test: FAILED: merge job $merge ended $state" >&2
      show_logs >&2
      exit 1 ;;
  esac
  if [ "$(date +%s)" -ge "$deadline" ]; then
    echo "ci-test: FAILED: merge job $merge is still '${state:-unknown}' after ${timeout} s" >&2
    show_logs >&2
    exit 1
  fi
  sleep 0.5
done
t1=$(now)
slurm_s=$(awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }')
for k in $(seq 0 $((n - 1))); do
  s=$(job_state "${array}_$k")
  [ "$s" = COMPLETED ] || { echo "ci-test: FAILED: shard task ${array}_$k is $s" >&2; show_logs >&2; exit 1; }
done

t2=$(now)
# shellcheck disable=SC2086
"$gibake" bake "$scene" -o "$single" $bake_args 2>"$work/single.log" \
  || { cat "$work/single.log" >&2; echo "ci-test: FAILED: the single-machine bake failed" >&2; exit 1; }
t3=$(now)
single_s=$(awk -v a="$t2" -v b="$t3" 'BEGIN { print b - a }')

if ! diff -r "$single" "$sharded" >&2; then
  echo "ci-test: FAILED: the merged asset differs from the single-machine bake" >&2
  exit 1
fi
files=$(find "$single" -type f | wc -l)
echo "slurm: merged asset is byte-identical to the single-machine bake ($files files)"
echo "slurm: scene $(basename "$scene"), $n shards, settings: $bake_args"
printf 'slurm: %d-shard bake + merge on the local Slurm: %.2f s (submit to merge done); single bake: %.2f s\n' \
  "$n" "$slurm_s" "$single_s"
