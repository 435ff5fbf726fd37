//! The integration tests of gibake-reference, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-reference --test integration FILE::`.

mod bundled;
mod common;
mod every_bounce;
mod many_lights;
mod physics;
