#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, validates the
# bundled glTF scenes with the Khronos validator, then runs every Rust test
# (GPU tests run on lavapipe when there is no GPU; they fail, never skip,
# when no adapter exists).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-deps.sh --node
echo "== glTF validator on data/*.glb"
(cd data/validate && npm ci --silent --no-audit --no-fund && node validate.mjs ../*.glb)
echo "== cargo test"
cargo test --workspace --release 2>&1
