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

/// The result of one `gibake` run.
pub struct Run {
    /// Exit code (`None` if killed by a signal).
    pub code: Option<i32>,
    /// Standard output.
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
    /// The command line, for messages.
    pub cmd: String,
}

impl std::fmt::Display for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "`{}` exited with {:?}\n--- stdout ---\n{}\n--- stderr ---\n{}",
            self.cmd, self.code, self.stdout, self.stderr
        )
    }
}

/// Runs a `gibake` command and captures its output.
pub fn run_command(mut c: std::process::Command) -> Run {
    let cmd = command_line(&c);
    let o = c.output().expect("cannot start the gibake binary");
    Run {
        code: o.status.code(),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        cmd,
    }
}

/// Small render settings so every GPU call takes well under a second on lavapipe.
pub const TINY_RENDER: [&str; 10] = [
    "--mode",
    "direct",
    "--width",
    "16",
    "--height",
    "16",
    "--shadow-map-size",
    "128",
    "--ssaa",
    "1",
];

/// Small bake settings (16 VPLs, tiny maps).
pub const TINY_BAKE: [&str; 8] = [
    "--vpls",
    "16",
    "--rsm-size",
    "64",
    "--vpl-map-size",
    "16",
    "--shadow-map-size",
    "256",
];

/// The command line of `c`, for messages.
pub fn command_line(c: &std::process::Command) -> String {
    format!(
        "gibake {}",
        c.get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    )
}

/// VPLs of the bake that checks `naive` = `full` in the frame-level
/// tests: the merge is the same per VPL whatever their number, and
/// `naive` re-renders every map each frame (at 664 VPLs 90% of a level's
/// judgement on lavapipe).
pub const NAIVE_VPLS: u32 = 64;

/// rel MSE of `naive` against `full` for `scene` baked with `s` at
/// [`NAIVE_VPLS`] VPLs ([`gibake_eval::levels::naive_against_full`]).
pub fn naive_against_full(
    ctx: &GpuContext,
    scene: &gibake_scene::Scene,
    s: &gibake_eval::EvalSettings,
) -> Result<f64, gibake_eval::EvalError> {
    let s = gibake_eval::EvalSettings {
        vpls: NAIVE_VPLS,
        ..s.clone()
    };
    gibake_eval::levels::naive_against_full(ctx, scene, &s)
}
