//! The integration tests of gibake-scenegen, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-scenegen --test integration FILE::`.

mod random_lights;
mod scenes;
