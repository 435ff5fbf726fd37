#!/usr/bin/env bash
# Bounded fuzzing of gibake's hostile-input surfaces (cargo-fuzz, libFuzzer):
#   gltf_import     the glTF import (.glb / .gltf bytes)
#   meshopt_decode  the meshopt decoder of EXT_/KHR_meshopt_compression views
#   webp_decode     the WebP decoder of EXT_texture_webp images
#   asset_manifest  the asset loader's manifest.bin decoding and validation
#   asset_exr       the asset loader's EXR map decoding
#   diff_tolerance  `gibake diff`'s tolerance parsing
# The corpus is seeded from data/*.glb and data/exports/ (real gltfpack and
# gltf-transform exports), fuzz/seeds/meshopt (compressed views of those
# exports), fuzz/seeds/webp, a small baked asset (fuzz/seeds/asset) and
# fuzz/seeds/diff_tolerance, plus every kept regression input. Each target
# runs FUZZ_SECONDS (default 20: six targets, the same two minutes in all as
# four targets of 30 s before) seconds. A crash is copied to
# fuzz/regressions/<target>/ (commit it: the plain `cargo test` regression
# tests in crates/scene and crates/asset replay every file there) and the
# script fails.
#
# Needs a nightly toolchain; installs cargo-fuzz when it is missing.
# FUZZ_SANITIZER (default `none`: gibake's crates deny unsafe code, and
# without AddressSanitizer the instrumented build is much faster, which keeps
# CI well under its time budget; `address` for a deeper local run).
# Usage: scripts/fuzz.sh [TARGET...]     (FUZZ_SECONDS=60 scripts/fuzz.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
seconds="${FUZZ_SECONDS:-20}"
san="${FUZZ_SANITIZER:-none}"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(gltf_import meshopt_decode webp_decode asset_manifest asset_exr diff_tolerance)
fi
if ! rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    echo "fuzz: no nightly toolchain (rustup toolchain install nightly); skipping" >&2
    exit 0
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "== installing cargo-fuzz"
    cargo install --locked cargo-fuzz
fi
echo "== building fuzz targets"
(cd fuzz && cargo +nightly fuzz build -O --sanitizer "$san" 2>&1 | tail -3)
status=0
for t in "${targets[@]}"; do
    corpus="fuzz/corpus/$t"
    mkdir -p "$corpus" "fuzz/artifacts/$t" "fuzz/regressions/$t"
    case "$t" in
        gltf_import) cp data/*.glb data/exports/*.glb data/exports/refused/*.glb "$corpus/" ;;
        meshopt_decode) cp fuzz/seeds/meshopt/* "$corpus/" ;;
        webp_decode) cp fuzz/seeds/webp/* "$corpus/" ;;
        asset_manifest) cp fuzz/seeds/asset/manifest.bin "$corpus/" ;;
        asset_exr) cp fuzz/seeds/asset/*.exr "$corpus/" ;;
        diff_tolerance) cp fuzz/seeds/diff_tolerance/* "$corpus/" ;;
    esac
    cp fuzz/regressions/"$t"/* "$corpus/" 2>/dev/null || true
    echo "== fuzzing $t for ${seconds}s"
    log=$(mktemp)
    set +e
    (cd fuzz && cargo +nightly fuzz run -O --sanitizer "$san" "$t" "corpus/$t" -- \
        -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=1048576 \
        -timeout=10 -print_final_stats=1) >"$log" 2>&1
    rc=$?
    set -e
    grep -E 'stat::number_of_executed_units|stat::peak_rss_mb|Done [0-9]+ runs' "$log" || true
    if [ $rc -ne 0 ]; then
        status=1
        echo "fuzz: $t FAILED (exit $rc); last lines:" >&2
        tail -30 "$log" >&2
        for f in fuzz/artifacts/"$t"/*; do
            [ -f "$f" ] || continue
            cp "$f" "fuzz/regressions/$t/"
            echo "fuzz: kept $f as fuzz/regressions/$t/$(basename "$f")" >&2
        done
    fi
    rm -f "$log"
done
exit $status
