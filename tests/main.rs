//! The end-to-end tests of the workspace, one test binary: each file of
//! tests/ is a module (its `//!` says what it checks), so the suite links
//! once instead of once per file, and the harness runs the files' tests
//! side by side on every core instead of one binary after another (a long
//! accuracy test no longer leaves a core idle). Run one file's tests with
//! `cargo test --release -p gibake --test end_to_end real_levels::`.

mod bake_flags;
mod below_horizon;
mod bench_frame;
mod bench_quick;
mod bench_small;
mod budget;
mod cascades;
mod ci_diff;
mod cli_basic;
mod cli_errors;
mod common;
mod direct_vs_reference;
mod every_bounce_accuracy;
mod every_bounce_judge;
mod every_light;
mod every_light_frame;
mod exports;
mod faults;
mod hostile;
mod indirect_accuracy;
mod indirect_effects;
mod interleave;
mod later_bounces;
mod pipeline;
mod pipeline_slurm;
mod readme;
mod real_levels;
mod runtime_modes;
mod spec_reader;
mod stiff_cases;
mod view;
mod winding;
