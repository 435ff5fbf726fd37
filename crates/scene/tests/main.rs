//! The integration tests of gibake-scene, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-scene --test integration FILE::`.

mod animation;
mod bad_input;
mod common;
mod extensions;
mod fuzz_regressions;
mod import;
mod valid_gltf;
