//! The integration tests of gibake-runtime, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-runtime --test integration FILE::`.

mod api;
mod game;
mod scene_options;
