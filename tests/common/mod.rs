//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use gibake_gpu::{GpuContext, GpuOptions};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("bake-cli has a parent")
        .to_owned()
}

/// A bundled scene in data/.
pub fn data(name: &str) -> PathBuf {
    root().join("data").join(name)
}

/// A GPU device, or a failure that says what to install. Never a skip.
pub fn gpu() -> GpuContext {
    match GpuContext::new(&GpuOptions::default()) {
        Ok(c) => c,
        Err(e) => panic!("GPU tests need an adapter: {e}"),
    }
}

/// The `gibake` binary built for this test run.
pub fn gibake() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_gibake"))
}
