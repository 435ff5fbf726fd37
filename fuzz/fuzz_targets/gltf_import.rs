//! Fuzzes the glTF import (`.glb` or `.gltf` bytes): any input must give a
//! scene or an error, never a panic (the import's own `catch_unwind` does not
//! hide one here: libFuzzer's panic hook aborts first), and stay within the
//! default budgets. External URIs resolve inside an empty directory.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("/nonexistent-fuzz-dir/fuzz.glb");
    let _ = gibake_scene::load_from_slice(data, path, &gibake_scene::LoadOptions::default());
});
