//! The integration tests of gibake-bake, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so they link once and
//! run side by side. One file's tests: `cargo test --release -p
//! gibake-bake --test integration FILE::`.

mod bake;
mod bake_lights;
mod cluster;
mod horizon;
mod later;
mod lights;
mod method_revision;
mod reach;
mod uptodate;
