#!/usr/bin/env bash
# Runs `gibake demo` on the bundled corner_bunny scene, installing what is
# missing first. Its images and asset go to target/gibake-demo/ (ignored by
# git) unless -o/--output is given.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-deps.sh
out=(-o target/gibake-demo)
for arg in "$@"; do
  case "$arg" in -o|--output|--output=*|-o?*) out=() ;; esac
done
cargo run --release -p gibake -- demo "${out[@]}" "$@"
