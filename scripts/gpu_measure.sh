#!/usr/bin/env bash
# The real-GPU measurements of docs/h100/, in one run (≈ 3.5 min on an H100
# with 16 CPU cores, before `bench frame` was added; far longer on lavapipe, which is not what it is for).
#
#   scripts/gpu_measure.sh [BIN_DIR] [OUT_DIR]
#
# BIN_DIR holds release builds of `gibake` (and, optionally, the pinned
# earlier binary `gibake-c2145de` of scripts/bench-frame.sh) and of the eval examples
# `cascade_cost`, `eval_levels` and `eval_lights` (default: target/release and
# target/release/examples; build them with
# `cargo build --release -p gibake -p gibake-eval --examples --bins`).
# Every command is also runnable on its own; this script only runs them in
# turn, each under a time limit, and writes its output into OUT_DIR
# (default: gpu-out): log.txt, and one folder per `gibake bench` run.
#
# The examples find the bundled levels by the path they were compiled in
# (crates/eval/../../data/levels): run the binaries on a copy of the
# repository at that same path, or build them where they run.
set -uo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
bin=${1:-$root/target/release}
out=${2:-gpu-out}
examples=$bin/examples
[ -x "$examples/cascade_cost" ] || examples=$bin
mkdir -p "$out"
log=$out/log.txt
: >"$log"

step() {
    local limit=$1
    shift
    echo "=== $(date -u +%T) $*" | tee -a "$log"
    local start
    start=$(date +%s%N)
    timeout "$limit" "$@" 2>&1 | tee -a "$log"
    local rc=${PIPESTATUS[0]}
    echo "=== rc=$rc wall=$((($(date +%s%N) - start) / 1000000)) ms" | tee -a "$log"
}

cd "$root"
command -v nvidia-smi >/dev/null &&
    nvidia-smi --query-gpu=name,driver_version --format=csv | tee -a "$log"
echo "cpus: $(nproc)" | tee -a "$log"

# The demo (bake, animation, per-pass times, error against the reference).
step 120 "$bin/gibake" demo --output "$out/demo"
# The paper's Table 1 at the paper's size, then the default sweep.
step 300 "$bin/gibake" bench table1 --table1-size 1280x720 --out "$out/table1-1280x720"
step 600 "$bin/gibake" bench --out "$out/bench"
# Per-pass frame time on every bundled real level (data/levels/levels.json),
# at the eval's size and at 720p.
levels=$(python3 -c 'import json; print(" ".join(l["name"] for l in json.load(open("data/levels/levels.json"))))' 2>/dev/null ||
    echo arena town living_room rooms roboblast cave city garden)
for size in "480 270" "1280 720"; do
    set -- $size
    for level in $levels; do
        step 120 "$examples/cascade_cost" "$level" --width "$1" --height "$2" --frames 8
    done
done
# Per-pass frame cost against the pinned earlier binary (issue 51, item 4;
# the commit is scripts/bench-frame.sh's PINNED): every bundled level at
# 1280×720, 664 VPLs, interleave 4, alternating renders. The baseline:
# $GIBAKE_BASELINE, else BIN_DIR/gibake-<commit> (scripts/bench-frame.sh
# builds one), else today's binary against itself (its `--bounces 1`
# columns still count).
pinned=$(sed -n 's/^PINNED=//p' scripts/bench-frame.sh)
baseline=${GIBAKE_BASELINE:-$bin/gibake-${pinned:0:7}}
[ -x "$baseline" ] || baseline=$bin/gibake
step 600 "$bin/gibake" bench frame --baseline "$baseline" --baseline-name "$(basename "$baseline")" \
    --size 1280x720 --vpls 664 --interleave 4 --level-list data/levels/levels.json \
    --work "$out/frame-work" \
    --markdown "$out/frame.md" --json "$out/frame.json"
# The real levels' accuracy (adapter-independent: compare with docs/results.md).
step 900 "$examples/eval_levels" --size 40 --blur 1 --markdown --out "$out/levels"
# Same scene, settings and adapter: identical bytes.
step 120 "$bin/gibake" bake data/corner_bunny.glb -o "$out/det1.gibake" --force
step 120 "$bin/gibake" bake data/corner_bunny.glb -o "$out/det2.gibake" --force
step 60 "$bin/gibake" diff "$out/det1.gibake" "$out/det2.gibake"

# Every light (issue 19). The same for a level baked with every light.
blenvy=data/lights/blenvy_start_level/StartLevel.glb
store=data/lights/pyraxia_store/Store.gltf
step 120 "$bin/gibake" bake "$blenvy" -o "$out/blenvy1.gibake" --force
step 120 "$bin/gibake" bake "$blenvy" -o "$out/blenvy2.gibake" --force
step 60 "$bin/gibake" diff "$out/blenvy1.gibake" "$out/blenvy2.gibake"
# Per-pass frame time of every light on two real levels at 720p (the
# third frame's passes in the stats file), and the 97-spot store with its
# lights culled and not.
step 120 "$bin/gibake" render "$blenvy" --bake "$out/blenvy1.gibake" \
    --width 1280 --height 720 --frames 3 -o "$out/blenvy_###.png" --stats "$out/blenvy_stats.json"
step 300 "$bin/gibake" bake "$store" -o "$out/store.gibake" --force
for culling in "" --no-light-culling; do
    step 120 "$bin/gibake" render "$store" --bake "$out/store.gibake" \
        --look-at 0,3,0,10,0,0 --width 1280 --height 720 --frames 3 $culling \
        -o "$out/store${culling}_###.png" --stats "$out/store${culling}_stats.json"
done
# Every light against the reference (adapter-independent: compare with
# docs/results.md, "Every light"); the CPU reference dominates.
step 600 "$examples/eval_lights" data/lamps.glb random:0..8 "$blenvy" --out "$out/lights"
