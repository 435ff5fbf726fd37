//! The integration tests of gibake-raycast, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-raycast --test integration FILE::`.

mod analytic;
mod near_origin;
mod negative_zero;
