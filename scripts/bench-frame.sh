#!/usr/bin/env bash
# `gibake bench frame` against the pinned earlier binary (issue 51, item 4):
# the per-pass frame cost of this checkout's gibake against the release
# binary of the commit pinned below, side by side in one run (ratios, not
# absolute times), on every bundled level.
#
#   scripts/bench-frame.sh [gibake bench frame options...]
#   scripts/bench-frame.sh --size 480x270 --markdown frame.md --json frame.json
#
# The pinned binary is built once (a git worktree of that commit and its own
# target directory, ~15 min on a 2-core machine) into a cache and reused:
#   GIBAKE_BASELINE_CACHE   the cache (default: target/bench-baseline)
#   GIBAKE_BASELINE         an existing binary to use instead (no build)
#   GIBAKE                  today's binary (default: built here, release)
set -euo pipefail

# The pinned commit: the one place it is written (docs/results.md, "Frame
# cost against c2145de", quotes it).
PINNED=c2145defdafdcb7c5a3ea661d5e4e46880f46c99

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
short=${PINNED:0:7}
if [ -z "${GIBAKE_BASELINE:-}" ]; then
    cache=${GIBAKE_BASELINE_CACHE:-$root/target/bench-baseline}
    GIBAKE_BASELINE=$cache/gibake-$short
    if [ ! -x "$GIBAKE_BASELINE" ]; then
        echo "== building gibake at $short (once) into $cache" >&2
        mkdir -p "$cache"
        if [ ! -d "$cache/src-$short" ]; then
            git worktree add --detach "$cache/src-$short" "$PINNED" >&2
        fi
        (cd "$cache/src-$short" &&
            CARGO_TARGET_DIR="$cache/target-$short" cargo build --release --locked -p gibake >&2)
        cp "$cache/target-$short/release/gibake" "$GIBAKE_BASELINE.tmp"
        mv "$GIBAKE_BASELINE.tmp" "$GIBAKE_BASELINE"
    fi
fi
if [ -z "${GIBAKE:-}" ]; then
    cargo build --release -p gibake >&2
    target_dir=$(cargo metadata --format-version 1 --no-deps |
        python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
    GIBAKE=$target_dir/release/gibake
fi
exec "$GIBAKE" bench frame --baseline "$GIBAKE_BASELINE" --baseline-name "$short" "$@"
