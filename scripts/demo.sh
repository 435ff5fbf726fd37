#!/usr/bin/env bash
# Runs `gibake demo` on the bundled corner_bunny scene, installing what is missing first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-deps.sh
cargo run --release -p gibake -- demo "$@"
