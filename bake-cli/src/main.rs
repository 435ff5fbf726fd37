//! `gibake`: the command-line front end. Thin: parses arguments, shows
//! progress, and calls the libraries (`gibake-scene`, `gibake-runtime`,
//! `gibake-reference`, ...). Exit codes: 0 success, 1 `diff` found a
//! difference, 2 bad input or usage (every error message names the file).

/// `eprintln!` for every module of this crate (it shadows std's, being
/// defined before them): a full or closed stderr (`gibake … 2>&1 | head -1`)
/// is ignored, as stdout's errors are, instead of panicking.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod cli;
mod commands;
mod demo;
mod guard;
mod limits;
mod output;
mod pipeline;
mod scene_diff;
mod view;

use std::process::ExitCode;

use clap::Parser;

/// Runs the parsed command line.
fn run(cli: cli::Cli) -> anyhow::Result<ExitCode> {
    use cli::Command;
    limits::set_memory_budget(cli.max_memory);
    match cli.command {
        Command::Render(a) => commands::render(a),
        Command::View(a) => view::view(a),
        Command::Reference(a) => commands::reference(a),
        Command::Demo(a) => demo::run(a),
        Command::Bake(a) => pipeline::bake(a),
        Command::Merge(a) => pipeline::merge(a),
        Command::Diff(a) => commands::diff(a),
        Command::Inspect(a) => commands::inspect(a),
        Command::Bench(a) => {
            gibake_bench::run(&a)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn main() -> ExitCode {
    // First, while this is the only thread.
    quiet_vulkan_device_select();
    let args = cli::Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_env("GIBAKE_LOG").unwrap_or_else(|_| {
        // winit's warnings about the X server's setup (XSETTINGS, a
        // virtual screen's size in mm) are not the user's to act on.
        tracing_subscriber::EnvFilter::new(if args.verbose {
            "info,winit=warn"
        } else {
            "warn,winit=error"
        })
    });
    // Colour only on a terminal: a log redirected to a file or a pipe gets
    // plain text, no ANSI escape codes.
    use std::io::IsTerminal;
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .log_internal_errors(false)
        .with_ansi(std::io::stderr().is_terminal())
        .without_time()
        .init();
    // SIGINT / SIGTERM / SIGHUP remove this process's temporaries and locks.
    if let Err(e) = gibake_output::signals::install() {
        eprintln!(
            "warning: cannot install the signal handler ({e}); an interrupted run may leave temporaries for the next run to remove"
        );
    }
    let code = match run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::from(2)
        }
    };
    // A signal's clean-up in progress ends the process itself.
    gibake_output::signals::finish();
    code
}

/// Environment variables with which a user chooses Vulkan layers or the
/// device themselves; any of them set, gibake changes nothing.
const VULKAN_CHOICES: [&str; 4] = [
    "NODEVICE_SELECT",
    "MESA_VK_DEVICE_SELECT",
    "VK_LOADER_LAYERS_ENABLE",
    "VK_LOADER_LAYERS_DISABLE",
];

/// Mesa's implicit Vulkan layer `VK_LAYER_MESA_device_select` (Debian's
/// `mesa-vulkan-drivers`) asks libwayland for a display when the devices
/// are enumerated, because wgpu enables `VK_KHR_wayland_surface`; with no
/// session (`XDG_RUNTIME_DIR` unset or not a directory: CI, ssh, batch
/// jobs) libwayland prints `error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment.` on each enumeration — an `error:` line on a run that
/// succeeds. Without a Wayland session the layer has no display to pick a
/// default GPU for, so gibake turns it off there (`NODEVICE_SELECT=1`, the
/// switch in the layer's own manifest) unless the user chose layers or a
/// device (see [`VULKAN_CHOICES`]). gibake picks its adapter itself
/// (`--adapter`, `GIBAKE_ADAPTER`, else the first real GPU).
#[allow(unsafe_code)]
fn quiet_vulkan_device_select() {
    let session = std::env::var_os("WAYLAND_DISPLAY").is_some()
        || std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| {
            std::path::Path::new(&d).is_absolute() && std::path::Path::new(&d).is_dir()
        });
    let chosen = VULKAN_CHOICES.iter().any(|v| std::env::var_os(v).is_some());
    if !session && !chosen {
        // SAFETY: called first thing in `main`, before any other thread
        // exists, so no other thread can read the environment meanwhile
        // (the one hazard `set_var` is `unsafe` for).
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// The error and its causes, `: `-separated, leaving out a cause whose text
/// the message already contains (library errors often quote their source).
fn error_chain(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}
