//! Fuzzes the decoding and validation of an asset's `manifest.bin`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = gibake_asset::testing::decode_manifest_bytes(data);
});
