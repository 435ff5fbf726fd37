//! `gibake`: the command-line front end. Thin: parses arguments, shows
//! progress, and calls the libraries (`gibake-scene`, `gibake-runtime`,
//! `gibake-reference`, ...). Exit codes: 0 success, 1 `diff` found a
//! difference, 2 bad input or usage (every error message names the file).

mod cli;
mod commands;
mod output;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_env("GIBAKE_LOG").unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(if args.verbose { "info" } else { "warn" })
    });
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .without_time()
        .init();
    match commands::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
