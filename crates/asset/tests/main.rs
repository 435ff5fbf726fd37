//! The integration tests of gibake-asset, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-asset --test integration FILE::`.

mod common;
mod corruption;
mod diff_inspect;
mod fuzz_regressions;
mod later;
mod lower;
mod owned_files;
mod ring_vpls;
mod roundtrip;
mod scene_options;
mod swept_bounds;
mod view_rsms;
mod write_safety;
