//! `gibake`: the command-line front end. Thin: parses arguments, shows
//! progress, and calls the libraries (`gibake-scene`, `gibake-runtime`,
//! `gibake-reference`, ...). Exit codes: 0 success, 1 `diff` found a
//! difference, 2 bad input or usage (every error message names the file).

mod bench;
mod cli;
mod commands;
mod demo;
mod limits;
mod output;
mod pipeline;

use std::process::ExitCode;

use clap::Parser;

/// Runs the parsed command line.
fn run(cli: cli::Cli) -> anyhow::Result<ExitCode> {
    use cli::Command;
    limits::set_memory_budget(cli.max_memory);
    match cli.command {
        Command::Render(a) => commands::render(a),
        Command::Reference(a) => commands::reference(a),
        Command::Demo(a) => demo::run(a),
        Command::Bake(a) => pipeline::bake(a),
        Command::Merge(a) => pipeline::merge(a),
        Command::Diff(a) => commands::diff(a),
        Command::Inspect(a) => commands::inspect(a),
        Command::Bench(a) => bench::bench(a),
    }
}

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_env("GIBAKE_LOG").unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(if args.verbose { "info" } else { "warn" })
    });
    // Colour only on a terminal: a log redirected to a file or a pipe gets
    // plain text, no ANSI escape codes.
    use std::io::IsTerminal;
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .without_time()
        .init();
    match run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::from(2)
        }
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
