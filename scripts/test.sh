#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, validates the
# bundled glTF scenes with the Khronos validator, then runs every Rust test
# (GPU tests run on lavapipe when there is no GPU; they fail, never skip,
# when no adapter exists), then a bounded fuzzing run (scripts/fuzz.sh).
# Slurm (slurm-wlm, munge) is installed for the one-node cluster test,
# tests/pipeline_slurm.rs, which fails when it cannot start. A Python venv
# (target/pyenv: numpy, OpenEXR, blake3) is made for tests/spec_reader.rs,
# which reads a baked asset with tools/spec_reader/read_gibake.py. strace is
# installed for the fault injection of tests/faults.rs. Xvfb is installed for
# tests/view.rs (`gibake view`'s window under a virtual X server). Then the
# Bevy plugin's tests (bevy/, its own workspace on nightly).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/ensure-deps.sh --node --slurm --python --faults --xvfb
echo "== glTF validator on data/*.glb and data/exports/ (real exporters' files)"
(cd data/validate && npm ci --silent --no-audit --no-fund &&
    node validate.mjs ../*.glb ../exports/*.glb ../exports/refused/*.glb)
echo "== cargo test"
log=$(mktemp)
set +e
cargo test --workspace --release --no-fail-fast 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
set -e
target_dir=$(cargo metadata --format-version 1 --no-deps |
    python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
if [ "${GIBAKE_BENCH_FRAME:-1}" != 0 ]; then
    # A report, not a timed test (≈ 1.5 min): the per-pass frame cost of
    # today's default against its own `--bounces 1` (and against itself as
    # the baseline: those ratios show the noise) on two small levels. It
    # never fails CI on times; tests/bench_frame.rs checks that it works.
    # GIBAKE_BENCH_FRAME=0 skips it.
    # Against the pinned earlier binary: scripts/bench-frame.sh.
    echo "== gibake bench frame --quick (a report; never fails CI)"
    cargo build --release -p gibake &&
        "$target_dir/release/gibake" bench frame --quick --levels corner_bunny,living_room \
            --baseline "$target_dir/release/gibake" --baseline-name "itself" \
            --work "$target_dir/bench-frame-ci" ||
        echo "warning: gibake bench frame failed (a report only; CI goes on)"
fi
# gibake-bevy (bevy/): the Bevy plugin, a workspace of its own on nightly
# (Bevy 0.20.1 declares rust-version 1.97.1; nightly 1.97.0 builds it with
# --ignore-rust-version: bevy/README.md). Its tests render with Bevy on
# lavapipe and compare with the gibake binary built above; Bevy is built
# with only the plugin's features, in bevy/'s dev profile (opt-level 1, no
# debug info). GIBAKE_BEVY=0 skips it.
if [ "${GIBAKE_BEVY:-1}" != 0 ]; then
    echo "== gibake-bevy (bevy/, nightly)"
    set +e
    cargo build --release -p gibake &&
        (cd bevy && GIBAKE="$target_dir/release/gibake" \
            cargo test --locked --ignore-rust-version --no-default-features --test integration) 2>&1 |
        tee -a "$log"
    bevy_status=${PIPESTATUS[0]}
    set -e
    if [ "$bevy_status" != 0 ]; then
        status=1
    fi
fi
# Bounded fuzzing (about 2 minutes: six targets of 20 s; needs nightly, installs cargo-fuzz;
# GIBAKE_FUZZ=0 skips it). A crash fails the run and is kept in
# fuzz/regressions/ for the plain regression tests.
if [ "${GIBAKE_FUZZ:-1}" != 0 ]; then
    echo "== fuzzing (scripts/fuzz.sh, ${FUZZ_SECONDS:-20} s per target)"
    if ! bash scripts/fuzz.sh; then
        status=1
    fi
fi
# One closing line over every test binary (cargo's last line is often a
# doc-test run with nothing in it).
totals=$(awk '/^test result:/ { for (i = 1; i < NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } } END { printf "%d %d", p, f }' "$log")
passed=${totals% *}
failed=${totals#* }
rm -f "$log"
echo
echo "tests: ${passed:-0} passed, ${failed:-0} failed"
exit "$status"
