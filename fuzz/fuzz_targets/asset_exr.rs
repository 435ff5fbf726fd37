//! Fuzzes the decoding of an asset's EXR maps (as a depth map and as the RSM).
//! The loader runs the `exr` crate under `catch_unwind`; a panic inside that
//! crate is turned into an error there, so the panic hook is silenced here
//! and only what escapes counts as a crash.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(init: { std::panic::set_hook(Box::new(|_| {})); }, |data: &[u8]| {
    let _ = gibake_asset::testing::decode_exr_bytes(data);
});
